"""The parent trusts nothing from the sandbox child: every field of its reply is validated.

The child runs untrusted code, so its ``result.json`` is hostile input. Names end up in file
paths (meshes, cache entries) and in USD prim paths, numbers in matrices and physics, and the
material in every export. :func:`model_from_json` checks each field against what the compiler
can legitimately produce and raises :class:`ResultError` (one line naming the field and why) at
the first that is not: cache keys are sha256 hex digests, names fully match ``[a-z0-9_]+``,
materials are library keys, every number is finite, matrices are rigid transforms, and every
count and string is bounded by ``config.SANDBOX``.
"""

from __future__ import annotations

import base64
import binascii
import math
import re
from typing import Any

import numpy as np

from ..config import MATERIAL, SANDBOX
from ..errors import ProceduraError
from ..findings import SEVERITIES
from ..materials import MATERIALS, Material, MaterialError, library_from_json
from ..mates import TYPES
from .model import CompiledCoupling, CompiledMate, CompiledModel, CompiledPart, Finding, cap_text
from .registry import DETAILS

#: Part, frame and mate names: the identifiers every exporter writes (USD prims, URDF links,
#: mesh file names), exactly what the registry accepts (``[a-z0-9_]+`` starting with a letter,
#: so also a valid USD prim name). Checked with ``re.fullmatch`` (``$`` would accept a
#: trailing newline).
NAME = re.compile(r"[a-z][a-z0-9_]{0,63}")
#: Param names: Python identifiers.
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
HEX_KEY = re.compile(r"[0-9a-f]{64}")
MAX_NAME = 128  # params and other identifiers
MAX_TEXT = 4096
MAX_ITEMS = 10_000
MAX_DEPTH = 4
RIGID_TOL = 1e-6


class ResultError(ProceduraError):
    """The child's result breaks the result schema (a compromised or broken child)."""


def _bad(where: str, why: str) -> ResultError:
    return ResultError(cap_text(f"the compile child returned an invalid result: {where} {why}", 300))


def _name(v: Any, where: str, pattern: re.Pattern[str] = NAME) -> str:
    if not isinstance(v, str) or len(v) > MAX_NAME or not pattern.fullmatch(v):
        raise _bad(where, f"= {v!r:.80} is not a name matching {pattern.pattern}")
    return v


def _text(v: Any, where: str, limit: int = MAX_TEXT) -> str:
    if not isinstance(v, str):
        raise _bad(where, f"is a {type(v).__name__}, not text")
    return cap_text(v, limit)


def _num(v: Any, where: str, *, lo: float = -math.inf) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < lo:
        raise _bad(where, f"= {v!r:.40} is not a finite number" + (f" >= {lo:g}" if lo > -math.inf else ""))
    return float(v)


def _int(v: Any, where: str, lo: int = 0) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo or v > 10**9:
        raise _bad(where, f"= {v!r:.40} is not an integer in [{lo}, 1e9]")
    return v


def _list(v: Any, where: str, limit: int = MAX_ITEMS) -> list[Any]:
    if not isinstance(v, list) or len(v) > limit:
        raise _bad(where, f"is not a list of at most {limit} items")
    return v


def _dict(v: Any, where: str, limit: int = MAX_ITEMS) -> dict[str, Any]:
    if not isinstance(v, dict) or len(v) > limit:
        raise _bad(where, f"is not an object of at most {limit} entries")
    return v


class _Rigid:
    """The matrices of one result: each is read and shape-checked as it comes
    (:meth:`matrix`), then all are checked together for being rigid transforms (:meth:`check`,
    one stacked test instead of a dozen small numpy calls per matrix; the error still names
    the first bad field)."""

    def __init__(self) -> None:
        self.items: list[tuple[str, np.ndarray]] = []

    def matrix(self, v: Any, where: str) -> np.ndarray:
        try:
            m = np.array(v, dtype=float)
        except (TypeError, ValueError):
            raise _bad(where, "is not a 4x4 matrix of numbers") from None
        if m.shape != (4, 4):
            raise _bad(where, "is not a finite 4x4 matrix")
        self.items.append((where, m))
        return m

    def check(self) -> None:
        """Raise for the first matrix that is not finite or not a rigid transform."""
        if not self.items:
            return
        m = np.stack([m for _, m in self.items])
        finite = np.isfinite(m).all(axis=(1, 2))
        if not finite.all():
            raise _bad(self.items[int(np.argmin(finite))][0], "is not a finite 4x4 matrix")
        r = m[:, :3, :3]
        ok = ((np.abs(m[:, 3] - [0, 0, 0, 1]).max(axis=1) <= RIGID_TOL)
              & (np.abs(np.einsum("nji,njk->nik", r, r) - np.eye(3)).max(axis=(1, 2)) <= RIGID_TOL)
              & (np.linalg.det(r) >= 0) & (np.abs(m[:, :3, 3]).max(axis=1) <= 1e9))
        if not ok.all():
            raise _bad(self.items[int(np.argmin(ok))][0], "is not a rigid transform")


def _plain(v: Any, where: str, depth: int = 0) -> Any:
    """JSON data of bounded depth and size whose numbers are finite."""
    if depth > MAX_DEPTH:
        raise _bad(where, "is nested too deeply")
    if v is None or isinstance(v, bool):
        return v
    if isinstance(v, (int, float)):
        return _num(v, where)
    if isinstance(v, str):
        return _text(v, where, MAX_NAME * 4)
    if isinstance(v, list):
        return [_plain(x, where, depth + 1) for x in _list(v, where, 256)]
    if isinstance(v, dict):
        return {_text(k, where, MAX_NAME): _plain(x, where, depth + 1) for k, x in _dict(v, where, 256).items()}
    raise _bad(where, f"holds a {type(v).__name__}")


def finding_from_json(f: Any, where: str) -> Finding:
    """A finding from the child's JSON, validated."""
    f = _dict(f, where, 16)
    extra = set(f) - {"code", "message", "part", "mate", "line", "value", "limit", "severity"}
    if extra:
        raise _bad(where, f"has unknown fields {sorted(extra)}")
    opt_num = {k: (None if f.get(k) is None or (isinstance(f[k], float) and math.isnan(f[k]))
                   else _num(f[k], f"{where}.{k}")) for k in ("value", "limit")}
    sev = f.get("severity", "error")
    if sev not in SEVERITIES:
        raise _bad(f"{where}.severity", f"= {sev!r:.40} is not one of {', '.join(SEVERITIES)}")
    return Finding(code=_name(f.get("code"), f"{where}.code", re.compile(r"[a-z0-9_-]+")),
                   message=_text(f.get("message"), f"{where}.message", SANDBOX.message_chars),
                   part=None if f.get("part") is None else _name(f["part"], f"{where}.part"),
                   mate=None if f.get("mate") is None else _name(f["mate"], f"{where}.mate"),
                   line=None if f.get("line") is None else _int(f["line"], f"{where}.line"),
                   severity=sev, value=opt_num["value"], limit=opt_num["limit"])


def _library(rows: Any) -> dict[str, Material]:
    """The built-in table plus the program's declared materials, every field checked."""
    try:
        declared = library_from_json(_list(rows, "materials", MATERIAL.max_declared))
    except MaterialError as exc:
        raise _bad("materials", f"are invalid: {exc}") from None
    shadow = sorted(set(declared) & set(MATERIALS))
    if shadow:
        raise _bad("materials", f"redeclare the built-in material(s) {', '.join(shadow)}")
    return {**MATERIALS, **declared}


def _part(p: Any, i: int, library: dict[str, Material], rigid: _Rigid,
          cache_dir: str | None = None) -> CompiledPart:
    where = f"parts[{i}]"
    p = _dict(p, where, 32)
    name = _name(p.get("name"), f"{where}.name")
    where = f"part {name}"
    material = p.get("material")
    if not isinstance(material, str) or material not in library:
        raise _bad(f"{where}.material", f"= {material!r:.40} is not a library material")
    if p.get("detail") not in DETAILS:
        raise _bad(f"{where}.detail", f"is not one of {', '.join(DETAILS)}")
    key = p.get("cache_key", "")
    if key != "" and not (isinstance(key, str) and HEX_KEY.fullmatch(key)):
        raise _bad(f"{where}.cache_key", f"= {key!r:.80} is not a sha256 hex digest")
    if p.get("cached") is True:
        data = _from_cache(cache_dir, key, where)
    else:
        data = _b64(p.get("brep"), f"{where}.brep")
    unpainted = _b64(p["unpainted"], f"{where}.unpainted") if "unpainted" in p else b""
    block_of = _name(p["block_of"], f"{where}.block_of") if "block_of" in p else ""
    lines = _list(p.get("lines"), f"{where}.lines", 2)
    if len(lines) != 2:
        raise _bad(f"{where}.lines", "is not a pair of line numbers")
    frames = _dict(p.get("frames", {}), f"{where}.frames", 256)
    return CompiledPart(
        name=name, brep=data, placement=rigid.matrix(p.get("placement"), f"{where}.placement"),
        frames={_name(k, f"{where}.frames key"): rigid.matrix(v, f"{where}.frames[{k}]")
                for k, v in frames.items()},
        material=material, detail=p["detail"],
        description=_text(p.get("description", ""), f"{where}.description", 1000),
        lines=(_int(lines[0], f"{where}.lines"), _int(lines[1], f"{where}.lines")),
        reads=tuple(_name(r, f"{where}.reads", IDENT) for r in _list(p.get("reads", []), f"{where}.reads", 4096)),
        cache_key=key, pieces=_pieces(p.get("pieces", 1), f"{where}.pieces"),
        mass=_positive(p.get("mass"), f"{where}.mass"),
        hollow=_positive(p.get("hollow"), f"{where}.hollow"),
        block_of=block_of, unpainted=unpainted, from_cache=p.get("cached") is True)


def _from_cache(cache_dir: str | None, key: str, where: str) -> bytes:
    """The stored BRep of a part the child says it loaded from the part cache: the parent's
    own copy (it wrote every entry), so nothing of the child's is read."""
    from . import cache
    if cache_dir is None:
        raise _bad(f"{where}.cached", "is set but this compile used no part cache")
    data = cache.load(cache_dir, key) if key else None
    if data is None:
        raise _bad(f"{where}.cached", f"names cache key {key[:12] or '(none)'} that the part "
                                      f"cache does not hold")
    return data


def _b64(v: Any, where: str) -> bytes:
    if not isinstance(v, str):
        raise _bad(where, "is not base64 text")
    try:
        return base64.b64decode(v, validate=True)
    except (binascii.Error, ValueError):
        raise _bad(where, "is not base64 text") from None


def _positive(v: Any, where: str) -> float | None:
    """An optional positive finite number (a declared mass or wall)."""
    if v is None:
        return None
    n = _num(v, where, lo=0.0)
    if n <= 0:
        raise _bad(where, f"= {n:g} is not positive")
    return n


def _pieces(v: Any, where: str) -> int:
    from .api import MAX_PIECES
    n = _int(v, where, 1)
    if n > MAX_PIECES:
        raise _bad(where, f"= {n} is over the {MAX_PIECES} a part may declare")
    return n


def _mate(m: Any, i: int, parts: dict[str, CompiledPart], rigid: _Rigid) -> CompiledMate:
    where = f"mates[{i}]"
    m = _dict(m, where, 32)
    name = _name(m.get("name"), f"{where}.name")
    where = f"mate {name}"
    mtype = m.get("type")
    if not isinstance(mtype, str) or mtype not in TYPES:
        raise _bad(f"{where}.type", f"= {mtype!r:.40} is not a mate type")
    if m.get("kind") != TYPES[mtype].kind:
        raise _bad(f"{where}.kind", f"is not {TYPES[mtype].kind!r}")
    ends = {}
    for role in ("child", "parent"):
        part = _name(m.get(role), f"{where}.{role}")
        frame = _name(m.get(f"{role}_frame"), f"{where}.{role}_frame")
        if part in parts and frame not in parts[part].frames:
            raise _bad(f"{where}.{role}", f"{part}.{frame} is not a frame of part {part}")
        ends[role], ends[f"{role}_frame"] = part, frame
    if not isinstance(m.get("primary", True), bool):
        raise _bad(f"{where}.primary", "is not true/false")
    fit, options, dof = (_plain(_dict(m.get(k), f"{where}.{k}", 64), f"{where}.{k}")
                         for k in ("fit", "options", "dof"))
    return CompiledMate(
        name=name, type=mtype, kind=TYPES[mtype].kind, **ends,
        nominal_name=_name(m.get("nominal_name"), f"{where}.nominal_name", IDENT),
        nominal=_num(m.get("nominal"), f"{where}.nominal", lo=0.0), fit=fit, options=options,
        dof=dof, world_frame=rigid.matrix(m.get("world_frame"), f"{where}.world_frame"),
        primary=m.get("primary", True),
        residual_mm=_num(m.get("residual_mm", 0.0), f"{where}.residual_mm", lo=0.0),
        residual_rad=_num(m.get("residual_rad", 0.0), f"{where}.residual_rad", lo=0.0),
        line=None if m.get("line") is None else _int(m["line"], f"{where}.line"))


def _coupling(c: Any, i: int, mates: dict[str, CompiledMate]) -> CompiledCoupling:
    from .couplings import SPECS
    where = f"couplings[{i}]"
    c = _dict(c, where, 16)
    ctype = c.get("type")
    if not isinstance(ctype, str) or ctype not in SPECS:
        raise _bad(f"{where}.type", f"= {ctype!r:.40} is not a coupling type")
    driven, driver = (_name(c.get(k), f"{where}.{k}") for k in ("driven", "driver"))
    for k, v in (("driven", driven), ("driver", driver)):
        if v not in mates or mates[v].kind != "kinematic":
            raise _bad(f"{where}.{k}", f"= {v!r} is not a kinematic mate of the result")
    name = _name(c.get("name"), f"{where}.name")
    if name != f"{driven}__{driver}":
        raise _bad(f"{where}.name", f"= {name!r} is not '{driven}__{driver}'")
    closes = c.get("closes", "")
    if closes != "":
        closes = _name(closes, f"{where}.closes")
    inputs = {_name(k, f"{where}.inputs key", IDENT): _name(v, f"{where}.inputs[{k}]", IDENT)
              for k, v in _dict(c.get("inputs", {}), f"{where}.inputs", 8).items()}
    values = {_name(k, f"{where}.values key", IDENT): _num(v, f"{where}.values[{k}]", lo=0.0)
              for k, v in _dict(c.get("values", {}), f"{where}.values", 8).items()}
    mesh = _list(c.get("mesh", ["", ""]), f"{where}.mesh", 2)
    if len(mesh) != 2:
        raise _bad(f"{where}.mesh", f"= {mesh!r:.80} is not a pair of part names")
    for x in mesh:  # a part that failed is not in the result (its mates still are)
        if x != "":
            _name(x, f"{where}.mesh")
    return CompiledCoupling(name=name, type=ctype, driven=driven, driver=driver,
                            ratio=_num(c.get("ratio"), f"{where}.ratio"),
                            offset=_num(c.get("offset", 0.0), f"{where}.offset"),
                            inputs=inputs, values=values, closes=closes,
                            line=None if c.get("line") is None else _int(c["line"], f"{where}.line"),
                            mesh=(str(mesh[0]), str(mesh[1])))


def model_from_json(d: Any, *, name: str | None = None, cache_dir: str | None = None) -> CompiledModel:
    """A :class:`CompiledModel` from the child's JSON, every field validated.

    Args:
        d: the decoded ``result.json``.
        name: the model name the parent asked for (used instead of the child's).
        cache_dir: the part cache the compile used: a part marked ``"cached"`` takes its BRep
            from there, by its key (an error when the cache does not hold the key).

    Raises:
        ResultError: the first field that is out of schema, named.
    """
    d = _dict(d, "the result", 16)
    parts_in = _list(d.get("parts"), "parts", SANDBOX.max_parts)
    library = _library(d.get("materials", []))
    parts: dict[str, CompiledPart] = {}
    rigid = _Rigid()
    for i, p in enumerate(parts_in):
        cp = _part(p, i, library, rigid, cache_dir)
        if cp.name in parts:
            raise _bad(f"part {cp.name}", "appears twice")
        if cp.block_of and (cp.block_of not in parts or parts[cp.block_of].block_of):
            raise _bad(f"part {cp.name}.block_of", f"= {cp.block_of!r} is not an earlier part")
        parts[cp.name] = cp
    mates = [_mate(m, i, parts, rigid) for i, m in enumerate(_list(d.get("mates"), "mates", 4 * SANDBOX.max_parts))]
    rigid.check()
    if len({m.name for m in mates}) != len(mates):
        raise _bad("mates", "repeat a name")
    params: dict[str, Any] = {}
    for k, v in _dict(d.get("params", {}), "params", 4096).items():
        _name(k, "params key", IDENT)
        params[k] = v if isinstance(v, bool) else (_text(v, f"param {k}", MAX_NAME) if isinstance(v, str)
                                                   else _num(v, f"param {k}"))
    timings = {_text(k, "timings key", 2 * MAX_NAME): _num(v, f"timings[{k!r:.40}]")
               for k, v in _dict(d.get("timings", {}), "timings", 6 * SANDBOX.max_parts + 64).items()}
    findings = [finding_from_json(f, f"findings[{i}]")
                for i, f in enumerate(_list(d.get("findings", []), "findings", 1000))]
    model_name = name if name is not None else _name(d.get("name"), "name", IDENT)
    by_name = {m.name: m for m in mates}
    from .couplings import MAX_COUPLINGS
    couplings = [_coupling(c, i, by_name)
                 for i, c in enumerate(_list(d.get("couplings", []), "couplings", MAX_COUPLINGS))]
    return CompiledModel(name=model_name, params=params, parts=list(parts.values()), mates=mates,
                         findings=findings, timings=timings, materials=library, couplings=couplings)
