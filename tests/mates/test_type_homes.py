"""One home per mate type: no code outside the vocabulary compares type names, and every type
and joint kind answers every question its consumers ask (feature macro, motion, Delta, home,
range check, joint kind, URDF / MJCF / UsdPhysics mapping)."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.errors import RangeError
from procedura_brep.mates.kinds import JOINT_KINDS, Motion, joint_kind
from procedura_brep.mates.vocabulary import TYPES, check_options

SRC = Path(__file__).resolve().parents[2] / "src" / "procedura_brep"
#: The homes of the names: the only modules that may spell a type name in code.
HOMES = {"mates/vocabulary.py", "mates/kinds.py"}
NAMES = frozenset(TYPES) | frozenset(JOINT_KINDS)


def _names_in(node: ast.AST) -> list[str]:
    """Type-name string constants directly in ``node`` (a constant, or a tuple/list/set of them)."""
    if isinstance(node, ast.Constant) and node.value in NAMES:
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [e.value for e in node.elts if isinstance(e, ast.Constant) and e.value in NAMES]
    return []


def name_comparisons(source: str) -> list[tuple[int, str]]:
    """``(line, text)`` of every comparison against a mate-type or joint-kind name literal
    (``t == "revolute"``, ``t in ("prismatic", "cylindrical")``, ``match`` cases) and every dict
    keyed by two or more of them (a per-type table kept outside the vocabulary)."""
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            if any(_names_in(o) for o in operands):
                out.append((node.lineno, ast.unparse(node)))
        elif isinstance(node, ast.MatchValue) and _names_in(node.value):
            out.append((node.lineno, f"case {ast.unparse(node.value)}"))
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if k is not None and _names_in(k)]
            if len(keys) >= 2:
                out.append((node.lineno, "{" + ", ".join(ast.unparse(k) for k in keys) + ": ...}"))
    return out


def test_no_type_name_comparison_outside_the_vocabulary():
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel in HOMES:
            continue
        bad += [f"{rel}:{line}: {text}" for line, text in name_comparisons(path.read_text("utf-8"))]
    assert not bad, ("compare mate types through the type (TYPES[name].motion, .joint_kind(...)) "
                     "or the joint kind (joint.kind.ball, .turns, .slides, ...), not by name:\n"
                     + "\n".join(bad))


def test_the_scanner_finds_planted_comparisons():
    planted = (
        'if j.type == "revolute":\n    pass\n'
        'ok = mtype not in ("prismatic", "cylindrical")\n'
        'MJ = {"continuous": "hinge", "spherical": "ball"}\n'
        'match t:\n    case "key":\n        pass\n'
        'fine = fit == "location" and {"revolute": 1}  # one key is not a table\n'
        '"""a docstring naming revolute == "revolute" is text, not code"""\n')
    found = name_comparisons(planted)
    assert [line for line, _ in found] == [1, 3, 4, 6], found


def _options(mtype) -> dict:
    """Valid options for a type (limits where it needs them)."""
    given = {"limits": (-10.0, 20.0)} if mtype.needs_limits else {}
    return check_options("m", mtype, mtype.default_fit, given)


#: The DOF signature each motion must declare: (translations, rotations).
DOF_OF = {Motion.NONE: ((), ()), Motion.TURN: ((), ("z",)), Motion.SLIDE: (("z",), ()),
          Motion.BALL: ((), ("x", "y", "z")), Motion.SLIDE_TURN: (("z",), ("z",))}
#: A non-zero joint value per motion.
VALUE_OF = {Motion.NONE: 5.0, Motion.TURN: 30.0, Motion.SLIDE: 7.0, Motion.BALL: (10.0, 5.0, 20.0),
            Motion.SLIDE_TURN: (7.0, 30.0)}


@pytest.mark.parametrize("name", list(TYPES))
def test_every_type_answers_every_question(name):
    from procedura_brep.mates.features import MACROS, build, macro
    mtype = TYPES[name]
    opts = _options(mtype)
    assert mtype.macro in MACROS and macro(name) is MACROS[mtype.macro]
    male, female = build(name, 10.0, mtype.resolve_fit(10.0, mtype.default_fit), opts)
    assert male is not None and female is not None and male.volume > 0 and female.volume > 0
    assert (tuple(mtype.dof.translation), tuple(mtype.dof.rotation)) == DOF_OF[mtype.motion]
    kind = mtype.joint_kind(opts)
    assert (kind is None) == (mtype.kind == "static") == (mtype.motion is Motion.NONE)
    home = mtype.home_value(opts)
    assert (home is None) == (kind is None)
    assert np.allclose(mtype.delta(home), np.eye(4)) and np.allclose(mtype.delta(None), np.eye(4))
    d = mtype.delta(VALUE_OF[mtype.motion])
    assert np.allclose(d[:3, :3] @ d[:3, :3].T, np.eye(3)) and np.allclose(d[3], [0, 0, 0, 1])
    if kind is None:
        assert np.allclose(d, np.eye(4))  # a static mate never moves its child
        return
    assert kind.motion is mtype.motion
    rotates, slides = bool(mtype.dof.rotation), bool(mtype.dof.translation)
    assert np.allclose(d[:3, :3], np.eye(3)) != rotates  # it turns exactly when it has a rotation
    assert (abs(d[2, 3]) > 1e-9) == slides and np.allclose(d[:2, 3], 0)  # only along Z
    if mtype.motion is not Motion.BALL:
        assert np.allclose(d[:3, 2], [0, 0, 1])  # the axis stays the axis


def _out_of_range(mtype):
    """A value just outside a type's range with its check's keyword arguments."""
    return {Motion.TURN: (21.0, {"limits": (-10.0, 20.0)}),
            Motion.SLIDE: (20.5, {"limits": (-10.0, 20.0)}),
            Motion.BALL: ((31.0, 0.0, 0.0), {"cone": 30.0}),
            Motion.SLIDE_TURN: ((0.0, 46.0), {"limits": (-10.0, 20.0),
                                              "angle_limits": (-45.0, 45.0)})}[mtype.motion]


@pytest.mark.parametrize("name", [n for n, t in TYPES.items() if t.kind == "kinematic"])
def test_every_kinematic_type_refuses_a_value_outside_its_range(name):
    mtype = TYPES[name]
    value, kw = _out_of_range(mtype)
    with pytest.raises(RangeError, match=f"m \\({name}\\)"):
        mtype.check_value("m", value, **kw)
    mtype.check_value("m", mtype.home_value(_options(mtype)), **kw)  # home is inside


@pytest.mark.parametrize("name", list(JOINT_KINDS))
def test_every_joint_kind_maps_onto_every_format(name):
    import mujoco
    from pxr import UsdPhysics
    kind = joint_kind(name)
    assert kind.name == name
    assert hasattr(UsdPhysics, kind.usd)
    if kind.compound:  # several 1-DOF joints, each a kind of its own
        assert kind.urdf is None and kind.mjcf is None and kind.usd_drive is None
        return
    assert kind.urdf in ("revolute", "continuous", "prismatic", "spherical")
    assert hasattr(mujoco.mjtJoint, f"mjJNT_{kind.mjcf.upper()}")
    assert (kind.usd_drive is None) == kind.ball
    assert kind.usd_drive in (None, "linear" if kind.slides else "angular")
    assert kind.unit == ("m" if kind.slides else "rad")
    assert kind.mate_unit == ("mm" if kind.slides else "deg")
    assert kind.default_drive == ("velocity" if kind.endless else "position")
    assert kind.to_si(180.0) == pytest.approx(0.18 if kind.slides else math.pi)


def test_every_joint_kind_is_some_types_joint():
    reached = set()
    for mtype in TYPES.values():
        if mtype.kind != "kinematic":
            continue
        for limits in ((-10.0, 20.0), None):
            if limits is None and mtype.needs_limits:
                continue
            reached.add(mtype.joint_kind({"limits": limits}).name)
    assert reached == set(JOINT_KINDS)


def test_unknown_joint_kind_names_the_known_ones():
    with pytest.raises(KeyError, match="unknown joint type 'hinge'.*revolute"):
        joint_kind("hinge")
