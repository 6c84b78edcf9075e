"""The AST policy on its own (no worker): every rule refuses its construct with its line, the
walk visits exactly what :func:`ast.walk` visits, and a node class the parser never makes is
held to its base class's rule. The attack corpus through the real sandbox is in
``test_sandbox.py``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from procedura_brep.program import allowlist as policy
from procedura_brep.program.allowlist import PolicyViolation

ROOT = Path(__file__).resolve().parents[2]
LAMP = (Path(__file__).parent / "lamp.py").read_text()

# (id, statement added at the end of the lamp's helpers, substring of the refusal)
RULES = [
    ("import", "import os", "import os"),
    ("import_alias", "import math as _m", "import math"),
    ("import_from", "from os import path", "from os import"),
    ("import_from_relative", "from . import x", "from None import"),
    ("import_from_api_names", "from procedura_brep.program import part", "import *"),
    ("import_private_name", "from math import _x", "'_x'"),
    ("import_reserved_alias", "from math import pi as open", "'pi'"),
    ("match", "match 1:\n    case 1:\n        pass", "match statements"),
    ("except_reserved", "try:\n    pass\nexcept ValueError as _e:\n    pass", "'_e'"),
    ("name_private", "x = _y", "'_y'"),
    ("name_builtin", "x = open", "'open'"),
    ("attribute_private", "x = math._y", "'_y'"),
    ("attribute_frames", "x = math.f_globals", "frames, code and globals"),
    ("attribute_store", "math.pi = 3", "assigning to the attribute"),
    ("def_private", "def _f():\n    pass", "'_f'"),
    ("class_private", "class _C:\n    pass", "'_C'"),
    ("async_def", "async def f():\n    pass", "async functions"),
    ("arg_private", "def f(_a):\n    pass", "'_a'"),
    ("global", "def f():\n    global g", "global/nonlocal"),
    ("nonlocal", "def f():\n    g = 1\n    def h():\n        nonlocal g", "global/nonlocal"),
    ("async_for", "async def f():\n    async for x in y:\n        pass", "async"),
    ("keyword_file", "x = dict(file=1)", "'file'"),
    ("keyword_private", "x = dict(_k=1)", "'_k'"),
    ("dunder_string", "x = '__class__'", "'__'"),
    ("subscript_write", "Solid.shape_constructors[1] = 2", "writing into Solid.shape_constructors"),
    ("mutator_call", "FONT_ASPECT.update({})", "calling FONT_ASPECT.update"),
]


def _inject(stmt: str) -> str:
    return LAMP.replace("# === parts ===", stmt + "\n\n# === parts ===")


@pytest.mark.parametrize("rid, stmt, needle", RULES, ids=[r[0] for r in RULES])
def test_each_rule_refuses_its_construct_with_its_line(rid, stmt, needle):
    src = _inject(stmt)
    with pytest.raises(PolicyViolation) as exc:
        policy.check(src)
    assert needle in str(exc.value), str(exc.value)
    first = src.splitlines().index(stmt.splitlines()[0]) + 1
    assert first <= exc.value.line <= first + len(stmt.splitlines()), (exc.value.line, first)


def test_a_name_the_program_binds_may_be_written():
    policy.check(_inject("d = {}\nd[1] = 2\nitems = []\nitems.append(1)"))


@pytest.mark.parametrize("path", ["tests/program/lamp.py",
                                  *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "golden").glob("*/program.py"))])
def test_the_walk_is_ast_walk_and_real_programs_pass(path):
    src = (ROOT / path).read_text()
    tree = ast.parse(src)
    assert [id(n) for n in policy._walk(tree)] == [id(n) for n in ast.walk(tree)]
    policy.check(src, tree=tree)


def test_a_node_class_the_parser_never_makes_is_held_to_its_base_rule():
    """The rules are looked up by class; a subclass of a ruled class falls back to its base's
    rule (planted: without the fallback, this tree passes)."""

    class OddName(ast.Name):
        pass

    tree = ast.parse("x = 1")
    tree.body[0].value = OddName(id="__import__", ctx=ast.Load(), lineno=1, col_offset=4)
    with pytest.raises(PolicyViolation, match="'__import__'"):
        policy.check("x = 1", tree=tree)
