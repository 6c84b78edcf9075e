"""Execute a program and compile it to a :class:`CompiledModel` (runs inside the sandbox child).

Steps: policy check -> exec with restricted builtins -> evaluate each part (a failure is a
finding naming the part, the program line and the exception) -> build each mate's features and
resolve its fit -> solve placement in plan order -> size caps -> serialise.

Module code and every part run in their own empty ``contextvars`` context, so a builder
(``BuildPart()``) that module code leaves open cannot capture the primitives a part creates;
leaving one open is itself an error. build123d's class-level tables are snapshotted before the
program runs and compared after: a program that wrote into one fails (nothing is cached).
"""

from __future__ import annotations

import ast
import builtins
import contextvars
import math
import sys
import time
import traceback
from collections.abc import Set as AbstractSet
from typing import Any, cast

import numpy as np

from ..config import SANDBOX, SandboxLimits
from ..errors import MateError, ProceduraError, ProgramFormatError
from ..findings import failed
from ..mates import check_options, get_type
from ..mates import placement as pl
from ..mates.kinds import Motion
from . import allowlist, blocks, cache, cachekeys, caps, couplings, guards, registry
from .model import CompiledMate, CompiledModel, CompiledPart, Finding
from .sections import parse_sections
from .values import as_solid as _as_solid
from .values import exc_text as _exc_text

SAFE_BUILTINS = (
    "abs", "all", "any", "bool", "dict", "divmod", "enumerate", "filter", "float", "frozenset",
    "int", "isinstance", "issubclass", "iter", "len", "list", "map", "max", "min", "next",
    "pow", "range", "repr", "reversed", "round", "set", "slice", "sorted", "str", "sum", "tuple",
    "zip", "print", "True", "False", "None", "Exception", "ValueError", "TypeError",
    "ArithmeticError", "ZeroDivisionError", "IndexError", "KeyError", "RuntimeError",
    "StopIteration", "NotImplemented",
)


def _guarded_import(name: str, globals_: Any = None, locals_: Any = None, fromlist: Any = (),
                    level: int = 0) -> Any:
    names = tuple(fromlist or ())
    if level == 0 and any(n.startswith("_") for n in names if n != "*"):
        raise ImportError("programs may not import names starting with '_'")
    if level == 0 and name == allowlist.PROGRAM_MODULE and names in ((), ("*",)):
        return builtins.__import__(name, globals_, locals_, fromlist, level)
    if level == 0 and name in allowlist.ALLOWED_IMPORTS:
        return builtins.__import__(name, globals_, locals_, fromlist, level)
    raise ImportError(f"programs may import only math and {allowlist.PROGRAM_MODULE}, not {name!r}")


def restricted_globals() -> dict[str, Any]:
    safe = {n: getattr(builtins, n) for n in SAFE_BUILTINS if hasattr(builtins, n)}
    safe["print"] = lambda *a, **k: None  # programs have no stdout
    safe["__import__"] = _guarded_import
    safe["__build_class__"] = builtins.__build_class__
    return {"__builtins__": safe, "__name__": "program"}


def _program_line(tb: Any) -> int | None:
    line = None
    for frame, lineno in traceback.walk_tb(tb):
        if frame.f_code.co_filename == "<program>":
            line = lineno
    return line


#: OCCT exception types that, in a primitive, mean a size was zero or negative.
_OCCT_SIZE_ERRORS = ("Standard_DomainError", "Standard_ConstructionError", "Standard_OutOfRange",
                     "gp_VectorWithNullMagnitude", "StdFail_NotDone")


def _explain(exc: BaseException, decl: registry.PartDecl, params: dict[str, Any],
             glb: dict[str, Any]) -> str:
    """Why a part failed, in words: the exception, plus the params it reads that are <= 0
    when the CAD kernel refused a construction (the usual cause of a raw OCCT error)."""
    text = _exc_text(exc)
    bad = [n for n in cachekeys.params_read(decl.fn.__code__, glb, params)
           if isinstance(params.get(n), (int, float)) and not isinstance(params.get(n), bool)
           and params[n] <= 0]
    occt = type(exc).__name__ in _OCCT_SIZE_ERRORS or type(exc).__module__.startswith("OCP")
    if bad and (occt or isinstance(exc, ValueError)):
        vals = ", ".join(f"{n} = {params[n]:g}" for n in bad)
        return (f"{text} (the CAD kernel refused a construction; this part reads {vals}: sizes "
                f"must be > 0)")
    if occt:
        return (f"{text} (the CAD kernel refused a construction: usually a zero or negative "
                f"size, or a fillet/chamfer too big for its edges)")
    return text


def loc_matrix(loc: Any) -> np.ndarray:
    """4x4 matrix of a build123d Location (or anything with ``.wrapped`` TopLoc_Location)."""
    t = loc.wrapped.Transformation()
    m = np.eye(4)
    for r in range(3):
        for c in range(4):
            m[r, c] = t.Value(r + 1, c + 1)
    return m


class _Build:
    """Mutable state of one compile."""

    def __init__(self, source: str, name: str) -> None:
        self.source, self.name = source, name
        self.findings: list[Finding] = []
        self.timings: dict[str, float] = {}
        self.solids: dict[str, Any] = {}
        self.world: dict[str, np.ndarray] = {}
        self.cached_bytes: dict[str, bytes] = {}
        self.figures: dict[str, caps.Figures] = {}
        self.limits: SandboxLimits = SANDBOX

    def fail(self, code: str, message: str, **kw: Any) -> None:
        self.findings.append(Finding(code, message, **kw))


def compile_program(source: str, *, name: str = "model", cache_dir: str | int | None = None,
                    limits: SandboxLimits = SANDBOX, share: tuple[int, int] | None = None) -> CompiledModel:
    """Compile ``source`` in this process. Call only inside the sandbox child.

    With ``share`` = (i, n) (a prebuild, share i of n of a parallel cold compile: see
    :meth:`~procedura_brep.program.sandbox.Worker.compile`), build just the final solids of
    this share of the parts that the cache lacks and return them for the cache (see
    :func:`_prebuilt`).

    Twins (parts with the same key, :func:`_twins`) are built once: the first in plan order is
    run, the others take its final solid.
    """
    b = _Build(source, name)
    b.limits = limits
    t0 = time.perf_counter()
    try:
        sections = parse_sections(source)
        allowlist.check(source, tree=sections.tree)
        known: set[str] = set()
        for p in sections.params.values():
            allowlist.check_param_expr(p.expr, line=p.line, known=known)
            known.add(p.name)
    except ProgramFormatError as exc:
        b.fail("format", str(exc), line=exc.line)
        return CompiledModel(name, {}, [], [], b.findings, b.timings)
    reg = registry.push()
    glb = restricted_globals()
    tables = guards.baseline()
    try:
        # parse_sections always keeps the tree it parsed
        contextvars.Context().run(_exec_module, b, cast(ast.Module, sections.tree), glb)
    finally:
        registry.pop()
    params = {k: glb.get(k) for k in sections.params}
    for k, v in list(params.items()):  # a function (part, helper) of a param's name rebinds it
        if callable(v):
            b.fail("format", f"param {k} is rebound by a function of the same name (a part or "
                             f"helper {k}()); give the param or the function another name",
                   part=k if k in reg.parts else None)
            b.findings.insert(0, b.findings.pop())  # the cause of what the rebinding broke
            del params[k]
    if not b.findings and not reg.parts:
        b.fail("no-parts", "the program declares no @part functions")
    n_parts = len(reg.parts) + len(reg.paints)  # colour blocks are parts of the model too
    if n_parts > limits.max_parts:
        b.fail("too-large", f"the program declares {n_parts} parts and blocks; the cap is "
                            f"{limits.max_parts} (config.SANDBOX.max_parts)", value=n_parts,
               limit=limits.max_parts)
    _check_materials(b, reg)
    if failed(b.findings):
        return CompiledModel(name, params, [], [], b.findings, b.timings)
    t = _lap(b, "exec_s", t0)
    mates = _resolve_mates(b, reg, params)
    scan = cachekeys.scan_module(source, sections.tree)
    volatile: set[str] = set()
    part_keys = cachekeys.part_keys(source, reg, params, mates, glb, scan=scan, volatile=volatile)
    t = _lap(b, "keys_s", t)
    hits = _load_cached(b, part_keys, cache_dir, painted={d.part for d in reg.paints})
    t = _lap(b, "cache_s", t)
    firsts, twins = _twins(reg, part_keys, volatile, hits)
    if share is not None:
        return _prebuilt(b, reg, params, glb, mates, part_keys, firsts[share[0]::share[1]], t0)
    _eval_parts(b, reg, hits, params, glb, skip=twins.keys())
    t = _lap(b, "parts_s", t)
    contextvars.Context().run(_apply_features, b, reg, mates, hits | twins.keys())
    t = _lap(b, "features_s", t)
    b.timings["twins"] = float(_adopt_twins(b, reg, mates, twins, params, glb))
    _place(b, reg, mates)
    t = _lap(b, "place_s", t)
    painted = blocks.apply_paint(b, reg, mates)  # colour blocks, cut after features and caching
    _check_model_caps(b, reg)
    t = _lap(b, "paint_caps_s", t)
    changed = guards.changed_tables(tables)
    if changed:
        b.fail("policy", f"the program modified build123d's class-level table(s) "
                         f"{', '.join(changed[:5])}; programs may not change the kernel")
    # state a part read that its key does not cover (a part that mutated a module-level list
    # or dict another part reads): those keys are dropped, so nothing stale is cached. Only a
    # key that hashed such a value can change (programs cannot rebind module names).
    after = cachekeys.part_keys(source, reg, params, mates, glb, scan=scan, only=volatile) \
        if volatile else {}
    part_keys = {n: k for n, k in part_keys.items()
                 if k and (n not in volatile or after.get(n) == k)}
    b.timings["cache_hits"] = float(len(hits))
    model = _serialise(b, reg, params, mates, time.perf_counter() - t0, part_keys)
    model.parts = blocks.with_blocks(b, model.parts, painted)
    if reg.couplings:  # after placement: signs come from the joints' world axes
        model.couplings, found = couplings.resolve(reg.couplings, model, {m.name for m in reg.mates})
        model.findings.extend(found)
    return model


def _twins(reg: registry.Registry, keys: dict[str, str], volatile: set[str],
           hits: AbstractSet[str]) -> tuple[list[str], dict[str, str]]:
    """Among the parts the cache lacks, keyed and not ``volatile``: the first part (plan order)
    of each key, and each twin -> its first. A twin has the same function text but for its
    name, reads the same values and gets the same mate features (``wheel_fl`` and ``wheel_rl``
    both ``return wheel(1)``), so the same solid. A part without a key or whose key hashed a
    mutable module value is in neither: its solid could depend on what ran before it."""
    first: dict[str, str] = {}
    twins: dict[str, str] = {}
    for n in reg.parts:
        k = keys.get(n, "")
        if not k or n in volatile or n in hits:
            continue
        if k in first:
            twins[n] = first[k]
        else:
            first[k] = n
    return list(first.values()), twins


def _failed_parts(b: _Build, mates: list[dict[str, Any]]) -> set[str]:
    """The parts a finding names, directly or through one of their mates."""
    named = {f.part for f in b.findings if f.part} | {f.mate for f in b.findings if f.mate}
    return named | {n for m in mates if m["decl"].name in named
                    for n in (m["decl"].child, m["decl"].parent)}


def _adopt_twins(b: _Build, reg: registry.Registry, mates: list[dict[str, Any]],
                 twins: dict[str, str], params: dict[str, Any], glb: dict[str, Any]) -> int:
    """Give each twin the final solid of the part it repeats (one object: placement moves a
    carrier, paint replaces the entry, serialising writes it once). A twin whose first failed
    (a finding names that part or one of its mates) is run on its own, so that its own
    findings name it. Returns how many twins took a solid without running."""
    failed_parts = _failed_parts(b, mates)
    redo: set[str] = set()
    for twin, first in twins.items():
        if first in b.solids and first not in failed_parts:
            b.solids[twin] = b.solids[first]
            b.figures[twin] = b.figures[first]
        else:
            redo.add(twin)
    if redo:
        others = set(reg.parts) - redo
        _eval_parts(b, reg, set(), params, glb, skip=others)
        contextvars.Context().run(_apply_features, b, reg, mates, others)
    return len(twins) - len(redo)


def _prebuilt(b: _Build, reg: registry.Registry, params: dict[str, Any], glb: dict[str, Any],
              mates: list[dict[str, Any]], part_keys: dict[str, str], share: list[str],
              t0: float) -> CompiledModel:
    """The parts of ``share`` (this child's share of the first parts of :func:`_twins`, dealt
    round robin in plan order: one per key, a twin is found in the cache under its first's
    key), each run and given its mate features, as unplaced parts under their keys (no
    placement, caps of the whole or paint: the compile that follows does those, with every part
    a cache hit). A part without a key or whose key hashed a mutable module value is in no
    share: its solid could depend on which other parts ran before it, and here only a share of
    them run."""
    from .. import kernel
    todo = set(share)
    rest = set(reg.parts) - todo
    _eval_parts(b, reg, rest, params, glb, skip=rest)
    contextvars.Context().run(_apply_features, b, reg, mates, rest)
    bad = _failed_parts(b, mates)
    parts = [CompiledPart(name=n, brep=kernel.write_brep(kernel.bake_location(b.solids[n].wrapped)),
                          placement=np.eye(4), frames={}, material=reg.parts[n].material,
                          detail=reg.parts[n].detail, cache_key=part_keys[n])
             for n in reg.parts if n in todo and n in b.solids and n not in bad]
    b.timings["compile_s"] = time.perf_counter() - t0
    return CompiledModel(b.name, {}, parts, [], b.findings, b.timings, reg.library)


def _lap(b: _Build, name: str, since: float) -> float:
    """Record the seconds since ``since`` as the compile's ``name`` stage; returns now."""
    now = time.perf_counter()
    b.timings[name] = now - since
    return now


def _exec_module(b: _Build, tree: ast.Module, glb: dict[str, Any]) -> None:
    """Run the module body, the very tree the policy checked (in its own context: see the
    module docstring)."""
    try:
        exec(compile(tree, "<program>", "exec"), glb)  # noqa: S102 - policy-checked, sandboxed
    except ProceduraError as exc:
        b.fail("declaration", str(exc), line=getattr(exc, "line", None) or _program_line(sys.exc_info()[2]),
               mate=getattr(exc, "mate", None))
    except BaseException as exc:  # noqa: BLE001 - any failure of program code is a finding - any failure of untrusted code is a finding
        b.fail("module-exception", _exc_text(exc), line=_program_line(exc.__traceback__))
    if guards.builder_open():
        b.fail("policy", "module-level code left a builder context (BuildPart/BuildSketch/"
                         "BuildLine) open; open builders only inside a part function, with `with`")


def _check_materials(b: _Build, reg: registry.Registry) -> None:
    """Every part names a material of the library (built-ins plus the program's own)."""
    library = reg.library
    for decl in reg.parts.values():
        if not isinstance(decl.material, str) or decl.material not in library:
            from ..text import did_you_mean
            b.fail("material", f"part {decl.name}: unknown material {decl.material!r:.60}"
                               f"{did_you_mean(decl.material, library)}; use one "
                               f"of: {', '.join(library)} (or declare it with material(...))",
                   part=decl.name, line=decl.line)


def _check_model_caps(b: _Build, reg: registry.Registry) -> None:
    if not b.figures or failed(b.findings):
        return
    why = caps.model_violation(b.figures, b.world, b.limits)
    if why:
        b.fail("too-large", why)


def _load_cached(b: _Build, keys: dict[str, str], cache_dir: str | int | None, *,
                 painted: AbstractSet[str] = frozenset()) -> set[str]:
    """Find the parts whose key is in the cache; return their names.

    A hit keeps its stored bytes (serialised unchanged: digests stay stable across builds).
    Its solid is read back only when this compile needs it, that is when the part is painted
    (its blocks are cut again) or the cache holds no figures for it (the caps are measured on
    the solid); otherwise its solid is ``None`` here: cached parts get no features, and their
    placement needs only their frames.
    """
    if cache_dir is None or cache_dir == "":
        return set()
    from .. import kernel
    hits: set[str] = set()
    for name, key in keys.items():
        data = cache.load(cache_dir, key)
        if data is None:
            continue
        fig = caps.figures_from_json(cache.load_figures(cache_dir, key)) if name not in painted else None
        if fig is not None:
            b.solids[name] = None
            b.figures[name] = fig
        else:
            try:
                b.solids[name] = _wrap(kernel.read_brep(data))
            except ProceduraError:
                continue
        b.cached_bytes[name] = data
        hits.add(name)
    return hits


def _wrap(shape: Any) -> Any:
    """A build123d Compound or Solid around a TopoDS_Shape."""
    from build123d import Compound, Solid
    return Compound(shape) if shape.ShapeType().name == "TopAbs_COMPOUND" else Solid(shape)


def _eval_parts(b: _Build, reg: registry.Registry, cached: set[str], params: dict[str, Any],
                glb: dict[str, Any], skip: AbstractSet[str] = frozenset()) -> None:
    for decl in reg.parts.values():
        if decl.name in skip:
            continue
        if decl.name in cached:
            if decl.name not in b.figures:
                b.figures[decl.name] = caps.measure(b.solids[decl.name].wrapped, b.limits)
            continue
        t = time.perf_counter()
        contextvars.Context().run(_eval_part, b, decl, params, glb)
        b.timings[f"part:{decl.name}"] = time.perf_counter() - t


def _eval_part(b: _Build, decl: registry.PartDecl, params: dict[str, Any], glb: dict[str, Any]) -> None:
    """Run one part function (in its own context) and check what it returned."""
    from .. import kernel
    try:
        solid = _as_solid(decl.fn())
        if guards.builder_open():
            raise ProgramFormatError("the part left a builder context open")
        fig = caps.measure(solid.wrapped, b.limits)
        why = caps.part_violation(decl.name, fig, b.limits)
        if why:
            b.fail("too-large", why, part=decl.name, line=decl.line)
            return
        vol = kernel.volume(solid.wrapped)
        if not vol > 0:
            raise ProgramFormatError(f"the solid is empty (volume {vol:g} mm^3)")
        if not kernel.is_valid(solid.wrapped):
            from .validity import invalid_origin
            origin = invalid_origin(decl.fn, glb)
            what = origin.text() if origin else "no traced operation returned it (an untraced constructor?)"
            b.fail("part-exception", f"part {decl.name}: the solid is not a valid B-rep (BRepCheck "
                   f"failed): {what}", part=decl.name, line=(origin and origin.line) or decl.line)
            return
        b.figures[decl.name] = fig
        b.solids[decl.name] = solid
    except BaseException as exc:  # noqa: BLE001 - any failure of program code is a finding
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            raise
        line = _program_line(exc.__traceback__) or decl.line
        b.fail("part-exception", f"part {decl.name}: {_explain(exc, decl, params, glb)}",
               part=decl.name, line=line)


def _frame(b: _Build, reg: registry.Registry, mname: str, part: str, frame: str) -> np.ndarray:
    if part not in reg.parts:
        from ..text import did_you_mean
        raise MateError(mname, f"unknown part {part!r}{did_you_mean(part, reg.parts)}; parts: "
                               f"{', '.join(reg.parts)}")
    frames = reg.frames.get(part, {})
    if frame not in frames:
        from ..text import did_you_mean
        raise MateError(mname, f"part {part!r} publishes no frame {frame!r}"
                               f"{did_you_mean(frame, frames)}; its frames: "
                               f"{', '.join(frames) or 'none (add frames(...))'}")
    return loc_matrix(frames[frame])


def _resolve_mates(b: _Build, reg: registry.Registry, params: dict[str, Any]) -> list[dict[str, Any]]:
    """Validate every mate and resolve its type, options, nominal, fit and frames (no geometry)."""
    out: list[dict[str, Any]] = []
    for decl in reg.mates:
        try:
            mtype = get_type(decl.name, decl.type)
            fit_name = decl.fit or mtype.default_fit
            opts = check_options(decl.name, mtype, fit_name, decl.options)
            if decl.nominal not in params:
                raise MateError(decl.name, f"nominal {decl.nominal!r} is not a param; params: "
                                           f"{', '.join(params) or 'none'}")
            d = params[decl.nominal]
            if isinstance(d, bool) or not isinstance(d, (int, float)) or not d > 0 or not math.isfinite(d):
                raise MateError(decl.name, f"nominal {decl.nominal} = {d!r} must be a positive number (mm)")
            try:
                fit = mtype.resolve_fit(float(d), fit_name)  # type: ignore[arg-type]  # a bad name: ValueError below
            except ValueError as exc:
                raise MateError(decl.name, str(exc)) from None
            fc = _frame(b, reg, decl.name, decl.child, decl.child_frame)
            fp = _frame(b, reg, decl.name, decl.parent, decl.parent_frame)
        except (MateError, ProceduraError) as exc:
            b.fail("mate", str(exc), mate=decl.name, line=decl.line)
            continue
        if decl.child == decl.parent:
            b.fail("mate", f"mate {decl.name}: a part cannot mate to itself", mate=decl.name, line=decl.line)
            continue
        out.append({"decl": decl, "type": mtype, "fit": fit, "options": opts, "d": float(d),
                    "fc": fc, "fp": fp})
    return out


def _apply_features(b: _Build, reg: registry.Registry, mates: list[dict[str, Any]],
                    cached: set[str]) -> None:
    """Add each mate's male half to its child and cut its female half from its parent (the
    other way round with ``male="parent"``).

    Parts in ``cached`` already hold their final solid (features included) and are skipped.
    """
    from ..mates import features
    for m in mates:
        decl, mtype = m["decl"], m["type"]
        to_male, to_female = features.sides(decl.child, decl.parent, m["options"])  # male= option
        frame_of = {decl.child: decl.child_frame, decl.parent: decl.parent_frame}
        todo_male = to_male in b.solids and to_male not in cached
        todo_female = to_female in b.solids and to_female not in cached
        if not (todo_male or todo_female):
            continue
        t = time.perf_counter()
        try:
            male, female = features.build(mtype.name, m["d"], m["fit"], m["options"])
            if male is not None and todo_male:
                b.solids[to_male] = b.solids[to_male] + (reg.frames[to_male][frame_of[to_male]] * male)
            if female is not None and todo_female:
                b.solids[to_female] = b.solids[to_female] - (reg.frames[to_female][frame_of[to_female]] * female)
        except Exception as exc:  # noqa: BLE001 - OCCT failures become findings
            b.fail("mate-feature", f"mate {decl.name}: building its {mtype.name} features failed: "
                                   f"{_exc_text(exc)}", mate=decl.name, line=decl.line)
        b.timings[f"mate:{decl.name}"] = time.perf_counter() - t


def _place(b: _Build, reg: registry.Registry, mates: list[dict[str, Any]]) -> None:
    """Place every child in plan order through build123d joints, checked against the closed form.

    The parent's ``RigidJoint`` sits at ``F_parent * Delta(home)`` and the child's at ``F_child``
    (static mates); a kinematic mate's child is moved to ``home`` by the mate's own build123d
    joint (RevoluteJoint / LinearJoint / BallJoint with its limits). The numpy closed form
    ``T_parent * F_parent * Delta * F_child^-1`` must agree within ``TOL.placement_*``.
    """
    from ..config import TOL
    from ..mates.joints import kinematic, rigid_place
    names = list(reg.parts)
    if not names:
        return
    b.world[names[0]] = np.eye(4)
    carriers = {n: _carrier(s) for n, s in b.solids.items()}
    jointed = {names[0]}
    cuts = {str(c.named.get("closes")) for c in reg.couplings if c.type == "linkage"}
    # the children of mates that failed before placing (a missing frame, a bad type): their
    # own children's "not placed" is a consequence, said as one
    kept = {m["decl"].name for m in mates}
    unplaced = {d.child: d.name for d in reg.mates if d.name not in kept}
    for m in mates:
        decl, mtype, opts = m["decl"], m["type"], m["options"]
        home = pl.home_value(mtype.name, opts) if mtype.kind == "kinematic" else None
        D = pl.delta(mtype.name, home)
        if decl.parent not in b.world:
            if decl.parent in unplaced:  # a consequence: the first error is the cause
                b.fail("unplaced", f"mate {decl.name}: parent {decl.parent!r} was not placed: it hangs "
                                   f"below mate {unplaced[decl.parent]}, which failed (fix that first)",
                       mate=decl.name, line=decl.line)
                unplaced[decl.child] = unplaced[decl.parent]
            else:
                b.fail("plan-order", f"mate {decl.name}: parent {decl.parent!r} is not placed yet; "
                                     f"declare mates in plan order (root: {names[0]!r})",
                       mate=decl.name, line=decl.line)
            continue
        solved = pl.solve(b.world[decl.parent], m["fp"], m["fc"], D)
        m["world_frame"] = b.world[decl.parent] @ m["fp"] @ D
        if decl.child == names[0]:
            b.fail("plan-order", f"mate {decl.name}: the root part {names[0]!r} cannot be a child",
                   mate=decl.name, line=decl.line)
        elif decl.child not in b.world:
            b.world[decl.child] = solved
            m["primary"] = True
            # a carrier is where the closed form says only if its own chain of joints ran
            # (a failed part upstream leaves its carrier at the origin)
            if decl.child in carriers and decl.parent in carriers and decl.parent in jointed:
                _place_by_joint(carriers, reg, m, solved, kinematic, rigid_place, b)
                jointed.add(decl.child)
        else:
            m["primary"] = False
            dist, ang = pl.residual(b.world[decl.child], solved)
            m["residual"] = (dist, ang)
            if mtype.kind == "kinematic" and decl.name in cuts:  # a linkage's cut joint
                gap = couplings.cut_gap(b.world[decl.parent], m["fp"], b.world[decl.child], m["fc"])
                if gap > TOL.residual_mm:
                    b.fail("loop", f"mate {decl.name}: the loop it closes does not meet at the compiled "
                                   f"pose: its two anchors are {gap:.4g} mm apart (limit "
                                   f"{TOL.residual_mm:g} mm); set the loop's home angles or lengths so "
                                   f"its frames meet", mate=decl.name, line=decl.line, value=gap,
                           limit=TOL.residual_mm)
            elif mtype.kind == "kinematic":
                b.fail("loop", f"mate {decl.name}: {decl.child!r} is already placed; a kinematic mate "
                               f"may not close a loop (unless a couple(..., \"linkage\", closes="
                               f"\"{decl.name}\") names it as the loop's cut)", mate=decl.name, line=decl.line)
            elif dist > TOL.residual_mm or ang > TOL.residual_rad:
                b.fail("mate-residual", f"mate {decl.name}: {decl.child!r} is placed by an earlier mate; "
                                        f"this one is off by {dist:.4g} mm and {math.degrees(ang):.4g} deg",
                       mate=decl.name, line=decl.line, value=dist, limit=TOL.residual_mm, severity="warning")
    for n in names[1:]:
        if n not in b.world and n in b.solids:
            b.fail("unmated", f"part {n!r} is joined to nothing: give it a mate to an earlier part",
                   part=n, line=reg.parts[n].line)


def _carrier(solid: Any) -> Any:
    """What the joints move for ``solid``: a new shape on the same TShape at the identity
    location, so the solid's own location, which is part of its local geometry, is never
    touched (build123d's ``copy.copy`` deep-copies the geometry first: 0.3 ms a box). A cached
    part not read back (``None``) gets an empty compound: a joint moves only its location."""
    from OCP.TopLoc import TopLoc_Location
    if solid is None:
        from OCP.BRep import BRep_Builder
        from OCP.TopoDS import TopoDS_Compound
        shape = TopoDS_Compound()
        BRep_Builder().MakeCompound(shape)
        return _wrap(shape)
    return _wrap(solid.wrapped.Located(TopLoc_Location()))


def _place_by_joint(carriers: dict[str, Any], reg: registry.Registry, m: dict[str, Any],
                    solved: np.ndarray, kinematic: Any, rigid_place: Any, b: _Build) -> None:
    """Move the child's carrier with build123d joints and check it against ``solved``."""
    decl, mtype, opts = m["decl"], m["type"], m["options"]
    parent, child = carriers[decl.parent], carriers[decl.child]
    fp = reg.frames[decl.parent][decl.parent_frame]
    fc = reg.frames[decl.child][decl.child_frame]
    try:
        if mtype.kind == "kinematic":
            home = pl.home_value(mtype.name, opts)
            joint = kinematic(mtype.name, parent, child, fp, fc, decl.name,
                              limits=opts.get("limits"), cone=opts.get("cone"),
                              angle_limits=opts.get("angle_limits"),
                              home=home if mtype.motion is Motion.SLIDE_TURN else (0.0, 0.0))
            joint.move(home)
        else:
            rigid_place(parent, child, fp, fc, decl.name)
    except ValueError as exc:
        b.fail("joint", f"mate {decl.name}: build123d refused the joint: {exc}", mate=decl.name,
               line=decl.line)
        return
    from ..config import TOL
    dist, ang = pl.residual(loc_matrix(child.location), solved)
    if dist > TOL.placement_mm or ang > TOL.placement_rad:
        b.fail("joint", f"mate {decl.name}: build123d's joint placement differs from the closed "
                        f"form by {dist:.3g} mm, {ang:.3g} rad (internal error)", mate=decl.name,
               line=decl.line, value=dist)


def _reads(decl: registry.PartDecl, params: dict[str, Any], reg: registry.Registry) -> tuple[str, ...]:
    names = set(decl.fn.__code__.co_names)
    for const in decl.fn.__code__.co_consts:
        if hasattr(const, "co_names"):
            names |= set(const.co_names)
    return tuple(sorted(n for n in names if n in params))


def _serialise(b: _Build, reg: registry.Registry, params: dict[str, Any],
               mates: list[dict[str, Any]], total: float, keys: dict[str, str]) -> CompiledModel:
    from .. import kernel
    parts: list[CompiledPart] = []
    written: dict[int, bytes] = {}  # id(solid) -> its BRep: twins share one solid, written once
    for name, decl in reg.parts.items():
        if name not in b.solids or name not in b.world:
            continue
        frames = {k: loc_matrix(v) for k, v in reg.frames.get(name, {}).items()}
        brep = b.cached_bytes.get(name)
        if not brep:
            solid = b.solids[name]
            brep = written.get(id(solid)) or kernel.write_brep(kernel.bake_location(solid.wrapped))
            written[id(solid)] = brep
        parts.append(CompiledPart(name=name, brep=brep,
                                  placement=b.world[name], frames=frames, material=decl.material,
                                  detail=decl.detail, description=decl.description,
                                  lines=(decl.line, decl.end_line), reads=_reads(decl, params, reg),
                                  cache_key=keys.get(name, ""), pieces=decl.pieces,
                                  mass=decl.mass, hollow=decl.hollow,
                                  from_cache=name in b.cached_bytes))
    cms: list[CompiledMate] = []
    for m in mates:
        if "world_frame" not in m:
            continue
        decl, mtype = m["decl"], m["type"]
        res = m.get("residual", (0.0, 0.0))
        cms.append(CompiledMate(
            name=decl.name, type=mtype.name, kind=mtype.kind, child=decl.child,
            child_frame=decl.child_frame, parent=decl.parent, parent_frame=decl.parent_frame,
            nominal_name=decl.nominal, nominal=m["d"], fit=m["fit"].as_dict(),
            options={k: (list(v) if isinstance(v, tuple) else v) for k, v in m["options"].items()},
            dof=mtype.dof.as_dict(), world_frame=m["world_frame"], primary=m.get("primary", True),
            residual_mm=res[0], residual_rad=res[1], line=decl.line))
    b.timings["compile_s"] = total
    clean = {k: v for k, v in params.items() if isinstance(v, (int, float, bool, str))}
    return CompiledModel(b.name, clean, parts, cms, b.findings, b.timings, reg.library)
