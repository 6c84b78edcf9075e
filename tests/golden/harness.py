"""Golden-file harness: summarise a compiled model as invariants and compare two summaries.

A summary holds what a person checks when a program changes: part names in plan order, counts,
per-part volume (mm^3), world bounding box (mm) and material, and every mate's type, kind,
partners, nominal, fit, DOF, limits and world frame (origin and +Z axis). Bytes are never
compared: volumes compare relatively and boxes and frames in millimetres.

Regenerate the golden files only on purpose::

    PROCEDURA_UPDATE_GOLDEN=1 python -m pytest tests/golden -q
"""

from __future__ import annotations

import difflib
import json
import os
from collections import Counter
from pathlib import Path
from typing import Any

from procedura_brep import kernel
from procedura_brep.program.model import CompiledModel

#: Environment variable that makes the golden tests rewrite expected files instead of comparing.
UPDATE_ENV = "PROCEDURA_UPDATE_GOLDEN"
GOLDEN_DIR = Path(__file__).resolve().parents[2] / "golden"
#: Digits kept in the stored JSON (well below the compare tolerances).
DIGITS = 6


def updating() -> bool:
    """True when the update flag is set (``PROCEDURA_UPDATE_GOLDEN=1``)."""
    return os.environ.get(UPDATE_ENV, "") not in ("", "0", "false", "False")


def _r(x: float) -> float:
    v = round(float(x), DIGITS)
    return 0.0 if v == 0 else v


def _limits(m: Any) -> Any:
    if m.type == "spherical":
        return {"cone_deg": _r(m.options["cone"])}
    lim = m.options.get("limits")
    return None if lim is None else [_r(v) for v in lim]


def summarize(model: CompiledModel) -> dict[str, Any]:
    """The golden summary of a compiled model (JSON-safe, deterministic)."""
    parts = []
    for p in model.parts:
        shape = p.shape()
        lo, hi = kernel.bbox(shape)
        parts.append({"name": p.name, "material": p.material, "detail": p.detail,
                      "volume_mm3": _r(kernel.volume(shape)),
                      "bbox_mm": [[_r(v) for v in lo], [_r(v) for v in hi]]})
    mates = []
    for m in model.mates:
        wf = m.world_frame
        mates.append({"name": m.name, "type": m.type, "kind": m.kind, "child": m.child,
                      "child_frame": m.child_frame, "parent": m.parent,
                      "parent_frame": m.parent_frame, "nominal_name": m.nominal_name,
                      "nominal_mm": _r(m.nominal), "fit": m.fit.get("fit"), "iso": m.fit.get("iso"),
                      "hole_mm": _r(m.fit["hole"]), "shaft_mm": _r(m.fit["shaft"]),
                      "dof": m.dof.get("count"), "limits": _limits(m),
                      "origin_mm": [_r(v) for v in wf[:3, 3]],
                      "z_axis": [_r(v) for v in wf[:3, 2]]})
    types = Counter(m.type for m in model.mates)
    return {
        "name": model.name,
        "counts": {"parts": len(model.parts), "mates": len(model.mates),
                   "static": sum(m.kind == "static" for m in model.mates),
                   "kinematic": sum(m.kind == "kinematic" for m in model.mates),
                   "by_type": dict(sorted(types.items()))},
        "findings": [f.as_dict() for f in model.findings],
        "parts": parts,
        "mates": mates,
    }


def _tol(path: str, volume_rel: float, bbox_mm: float, frame_mm: float) -> tuple[str, float]:
    key = path.rsplit(".", 1)[-1].split("[", 1)[0]
    if key == "volume_mm3":
        return "rel", volume_rel
    if key == "bbox_mm":
        return "abs", bbox_mm
    if key in ("origin_mm", "z_axis"):
        return "abs", frame_mm
    return "abs", 1e-9


def compare(expected: Any, actual: Any, *, volume_rel: float = 1e-6, bbox_mm: float = 1e-3,
            frame_mm: float = 1e-6) -> list[str]:
    """Readable differences ``path: expected vs actual`` between two summaries (empty = equal).

    Numbers compare within tolerances chosen by the key: ``volume_mm3`` relatively, ``bbox_mm``
    and frame entries (``origin_mm``, ``z_axis``) absolutely; everything else exactly.
    """
    out: list[str] = []

    def walk(e: Any, a: Any, path: str) -> None:
        if isinstance(e, dict) and isinstance(a, dict):
            for k in sorted(set(e) | set(a), key=str):
                p = f"{path}.{k}" if path else str(k)
                if k not in a:
                    out.append(f"{p}: expected {e[k]!r} vs missing")
                elif k not in e:
                    out.append(f"{p}: unexpected {a[k]!r}")
                else:
                    walk(e[k], a[k], p)
        elif isinstance(e, list) and isinstance(a, list):
            if len(e) != len(a):
                out.append(f"{path}: expected {len(e)} items vs {len(a)}")
            for i, (x, y) in enumerate(zip(e, a)):
                label = x.get("name") if isinstance(x, dict) and "name" in x else i
                walk(x, y, f"{path}[{label}]")
        elif (isinstance(e, (int, float)) and isinstance(a, (int, float))
              and not isinstance(e, bool) and not isinstance(a, bool)):
            mode, tol = _tol(path, volume_rel, bbox_mm, frame_mm)
            limit = tol * max(abs(e), abs(a), 1.0) if mode == "rel" else tol
            if abs(e - a) > limit:
                out.append(f"{path}: expected {e!r} vs {a!r}")
        elif e != a:
            out.append(f"{path}: expected {e!r} vs {a!r}")

    walk(expected, actual, "")
    return out


def dumps(summary: dict[str, Any]) -> str:
    """The canonical JSON text of a summary (what golden files hold)."""
    return json.dumps(summary, indent=1, sort_keys=False) + "\n"


def unified_diff(expected: dict[str, Any], actual: dict[str, Any], name: str) -> str:
    """A unified diff of the two summaries' JSON, for a failing test's message."""
    return "".join(difflib.unified_diff(dumps(expected).splitlines(keepends=True),
                                        dumps(actual).splitlines(keepends=True),
                                        fromfile=f"{name} (expected)", tofile=f"{name} (actual)"))


def check(expected_path: Path, actual: dict[str, Any]) -> None:
    """Compare ``actual`` with the file (or rewrite it under the update flag); fail with a diff."""
    if updating():
        expected_path.parent.mkdir(parents=True, exist_ok=True)
        if expected_path.name == "expected.json" or not expected_path.exists():
            expected_path.write_text(dumps(actual), encoding="utf-8")
        return
    expected = json.loads(expected_path.read_text(encoding="utf-8"))
    diffs = compare(expected, actual)
    if diffs:
        raise AssertionError(f"{expected_path} differs ({len(diffs)} differences):\n"
                             + "\n".join(diffs[:40]) + "\n\n" + unified_diff(expected, actual, expected_path.name)
                             + f"\nIf the change is intended, rerun with {UPDATE_ENV}=1 and commit the diff.")
