"""The offline viewer: ``viewer.html`` and its ``viewer/`` folder, opened from the file system.

A browser opening a page from ``file://`` refuses ES modules and ``fetch()``, so the page loads
classic scripts that sit beside it and set globals:

* ``viewer/three.min.js``: three.js (:data:`THREE_VERSION`, MIT, ``viewer/LICENSE-three``) with
  OrbitControls and RoomEnvironment, bundled from the npm registry by
  ``viewer_assets/vendor/vendor.sh``; sets ``THREE``.
* ``viewer/data.js``: :func:`viewer_data` of the model as ``window.PROCEDURA_VIEWER``: every
  part's mesh in part-local coordinates (the exports' tessellation, float32 positions, int8
  normals, base64), the links and joints of the articulation (the URDF's frames: a child link's
  origin is its joint's anchor, +Z its axis), the slider ranges and the mate frames.
* ``viewer/findings.js``: :func:`findings_js` of the run's report as
  ``window.PROCEDURA_FINDINGS``; the bundle writes an empty one, the build rewrites it when
  report.json is final.
* ``viewer/app.js``: the page's logic (the part tree, joint sliders, exploded view, mate frames,
  findings).

Matrices are 4x4, millimetres, column-major lists of 16 (three.js's ``Matrix4.fromArray``).
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Mapping
from importlib import resources
from typing import Any

import numpy as np

from ..articulation.tree import Articulation, Joint
from ..mates.kinds import JointKind
from ..program.model import CompiledModel
from .meshes import part_mesh, smooth_normals

#: The three.js release bundled into ``viewer/three.min.js`` (``vendor/vendor.sh`` pins it).
THREE_VERSION = "0.187.0"
#: The data layout of ``viewer/data.js`` (bumped when app.js needs a different one).
DATA_FORMAT = 1
#: The range a slider of a joint without limits (a continuous turn) spans, deg.
ENDLESS_DEG = 180.0
#: The package folder holding the page, its script and the vendored three.js.
ASSETS = "viewer_assets"
#: Run-dir path -> asset file name, copied as they are.
STATIC: dict[str, str] = {"viewer.html": "viewer.html", "viewer/app.js": "app.js",
                          "viewer/three.min.js": "three.min.js",
                          "viewer/LICENSE-three": "LICENSE-three"}
#: The findings script, rewritten by the build when its report is final.
FINDINGS_JS = "viewer/findings.js"


def _asset(name: str) -> bytes:
    return resources.files(__package__).joinpath(ASSETS, name).read_bytes()


def _cols(m: np.ndarray) -> list[float]:
    """A 4x4 as three.js reads it: column-major, 16 floats."""
    return [float(x) for x in np.asarray(m, dtype=float).flatten(order="F")]


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def _mesh_entry(model: CompiledModel, name: str) -> dict[str, Any]:
    """One part's mesh in its own coordinates: the exports' triangles and crease-aware normals
    (:func:`.meshes.smooth_normals`, as the GLB's) moved by the inverse placement."""
    part = model.part(name)
    mesh, normals = smooth_normals(part_mesh(part))
    inv = np.linalg.inv(np.asarray(part.placement, dtype=float))
    local = mesh.vertices @ inv[:3, :3].T + inv[:3, 3]
    nrm = normals @ inv[:3, :3].T
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    faces = np.asarray(mesh.faces)
    index = faces.astype("<u2" if len(local) < 65536 else "<u4")
    lo, hi = (local.min(axis=0), local.max(axis=0)) if len(local) else (np.zeros(3), np.zeros(3))
    return {"positions": _b64(local.astype("<f4")), "normals": _b64(np.round(nrm * 127).astype(np.int8)),
            "indices": _b64(index),
            "index_bytes": int(index.dtype.itemsize), "triangles": int(len(faces)),
            "center": [float(x) for x in (lo + hi) / 2]}


def _scale(kind: JointKind) -> float:
    """SI (rad, m) to a slider's unit (deg, mm)."""
    return 1000.0 if kind.slides else math.degrees(1.0)


def _dofs(j: Joint, art: Articulation) -> tuple[list[dict[str, Any]], str | None]:
    """The sliders of joint ``j`` (deg or mm, relative to the compiled pose as the URDF's
    positions are) and a note for what has none. A joint a coupling drives (a gear, a rack, a
    screw, a belt) follows the joint at the head of its chain: ``driver``, and ``ratio`` and
    ``offset`` in slider units (``value = offset + ratio * driver's value``), as the URDF's
    ``<mimic>``."""
    out = []
    note = None
    for d in j.dofs():
        kind = d.kind
        scale = _scale(kind)
        if d.lower is None or d.upper is None:
            lo, hi = -ENDLESS_DEG, ENDLESS_DEG
        else:
            lo, hi = d.lower * scale, d.upper * scale
        row: dict[str, Any] = {"name": d.name, "type": d.type,
                               "motion": "slide" if kind.slides else "turn",
                               "unit": "mm" if kind.slides else "deg", "lower": lo, "upper": hi,
                               "endless": d.lower is None}
        coupling = j.coupling
        if coupling is not None and d.name == j.name:
            if coupling.type == "linkage":  # no constant ratio: a closed loop
                note = "in a closed loop (a linkage): posed on its own here, the loop is not solved"
            else:
                head, ratio, offset = art.root_driver(j.name)
                row.update(driver=head, coupling=coupling.type,
                           ratio=ratio * scale / _scale(art.joint(head).kind),
                           offset=offset * scale)
        out.append(row)
    if j.kind.ball:
        note = "a ball joint (3 rotations): not posed here"
    return out, note


def viewer_data(model: CompiledModel, art: Articulation) -> dict[str, Any]:
    """``window.PROCEDURA_VIEWER``: parts (meshes, materials, link), links (rest matrix in the
    parent link, world frame), joints (sliders) and mates (world frames)."""
    links = []
    for lk in art.links:
        joint = art.joint(lk.parent_joint) if lk.parent_joint else None
        parent = art.link(joint.parent).frame if joint else np.eye(4)
        links.append({"name": lk.name, "parent": joint.parent if joint else None,
                      "joint": joint.name if joint else None, "parts": list(lk.parts),
                      "rest": _cols(np.linalg.inv(parent) @ lk.frame), "world": _cols(lk.frame)})
    joints = []
    for j in art.joints:
        dofs, note = _dofs(j, art)
        joints.append({"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                       "world": _cols(j.frame), "flipped": j.flipped, "dofs": dofs, "note": note,
                       "subtree": art.subtree(j.child)})
    parts = []
    for p in model.parts:
        lk = art.link(art.part_link[p.name])
        m = model.material_of(p)
        parts.append({"name": p.name, "material": p.material, "rgb": [float(c) for c in m.rgb],
                      "metalness": float(m.metalness), "roughness": float(m.roughness),
                      "detail": p.detail, "description": p.description, "block_of": p.block_of,
                      "link": lk.name, "local": _cols(np.linalg.inv(lk.frame) @ p.placement),
                      "placement": _cols(p.placement), **_mesh_entry(model, p.name)})
    mates = [{"name": m.name, "type": m.type, "kind": m.kind, "child": m.child,
              "parent": m.parent, "world": _cols(m.world_frame),
              "in_parent": _cols(np.linalg.inv(model.part(m.parent).placement) @ m.world_frame)}
             for m in model.mates]
    return {"format": DATA_FORMAT, "name": model.name, "units": "mm", "up": "+Z",
            "three": THREE_VERSION, "base": art.base, "parts": parts, "links": links,
            "joints": joints, "mates": mates}


def _script(var: str, data: Mapping[str, Any]) -> bytes:
    # ASCII-only JSON is a valid JS expression (no U+2028 surprises); names stay data, never HTML
    return f"window.{var} = {json.dumps(data, ensure_ascii=True, separators=(',', ':'))};\n".encode()


def findings_data(report: Mapping[str, Any] | None) -> dict[str, Any]:
    """What the page lists: the report's status and findings, then the gates' warnings and
    infos not already among them (one row per distinct code, part and message)."""
    if report is None:
        return {"status": None, "findings": [], "note": "no report.json yet: build this program"}
    rows: list[dict[str, Any]] = []
    seen: set[tuple[Any, ...]] = set()
    gates = report.get("gates") if isinstance(report.get("gates"), Mapping) else {}
    for f in [*(report.get("findings") or []), *((gates or {}).get("findings") or [])]:
        if not isinstance(f, Mapping):
            continue
        key = (f.get("code"), f.get("part"), f.get("message"))
        if key in seen:
            continue
        seen.add(key)
        rows.append({k: f[k] for k in ("code", "message", "severity", "part", "other", "mate")
                     if f.get(k) is not None})
    order = {"error": 0, "warning": 1, "info": 2}
    rows.sort(key=lambda r: order.get(str(r.get("severity", "error")), 3))
    return {"status": report.get("status"), "findings": rows}


def findings_js(report: Mapping[str, Any] | None) -> bytes:
    """``viewer/findings.js`` for ``report`` (None: a build has not reported yet)."""
    return _script("PROCEDURA_FINDINGS", findings_data(report))


def _articulation(model: CompiledModel) -> tuple[Articulation, str | None]:
    """The model's articulation, or (mates that are not a tree) one rigid link of every part
    and the reason, so the page still shows the parts."""
    from ..articulation.tree import ArticulationError, Link, articulate
    try:
        return articulate(model), None
    except ArticulationError as exc:
        if not model.parts:
            raise
        root = model.parts[0]
        names = [p.name for p in model.parts]
        flat = Articulation(model.name, [Link(root.name, names, np.asarray(root.placement, float))],
                            [], {n: root.name for n in names})
        return flat, f"no joints shown: {exc}"


def viewer_files(model: CompiledModel, art: Articulation | None = None) -> dict[str, bytes]:
    """``viewer.html`` and ``viewer/*`` of ``model`` as ``{relative path: bytes}`` (pure);
    ``art`` is the bundle's articulation (default: :func:`articulate` of ``model``; a mate
    graph that is not a tree is shown as one rigid body, with the reason)."""
    note = None
    if art is None:
        art, note = _articulation(model)
    data = viewer_data(model, art)
    if note:
        data["note"] = note
    out = {rel: _asset(name) for rel, name in STATIC.items()}
    out["viewer/data.js"] = _script("PROCEDURA_VIEWER", data)
    out[FINDINGS_JS] = findings_js(None)
    return out


__all__ = ["FINDINGS_JS", "THREE_VERSION", "findings_data", "findings_js", "viewer_data",
           "viewer_files"]
