"""The layer table (src/procedura_brep/layers.toml) holds for every import in src/, lazy ones
included; importing the providers loads no CAD, numeric or GL module."""

from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "src" / "procedura_brep"
TABLE = tomllib.loads((ROOT / "layers.toml").read_text(encoding="utf-8"))


def _unit(dotted: str) -> str:
    """The top-level unit of ``procedura_brep.x.y`` (``__init__`` for names of the package)."""
    parts = dotted.split(".")
    if len(parts) == 1:
        return "__init__"
    name = parts[1]
    if (ROOT / f"{name}.py").exists() or (ROOT / name / "__init__.py").exists():
        return name
    return "__init__"  # e.g. ``from procedura_brep import __version__``


def _targets(path: Path) -> list[tuple[int, str]]:
    """Every ``procedura_brep`` module ``path`` imports, with its line (relative, absolute,
    inside functions, and ``importlib.import_module`` with a literal name)."""
    rel = path.relative_to(ROOT.parent).with_suffix("")
    package = list(rel.parts if path.name == "__init__.py" else rel.parts[:-1])
    if path.name == "__init__.py":
        package = package[:-1]
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("procedura_brep"):
                continue
            if mod == "procedura_brep":
                out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
            else:
                out.append((node.lineno, mod))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("procedura_brep")]
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module"
              and node.args and isinstance(node.args[0], ast.Constant)
              and str(node.args[0].value).startswith("procedura_brep")):
            out.append((node.lineno, str(node.args[0].value)))
    return out


def violations(root: Path = ROOT) -> list[str]:
    """Every import that breaks the table, as ``file:line: a -> b (why)``."""
    rank = {u: i for i, layer in enumerate(TABLE["order"]) for u in layer}
    side = TABLE["side"]
    bad = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent)
        src = _unit(".".join(rel.with_suffix("").parts))
        for line, target in _targets(path):
            dst = _unit(target)
            if dst == src:
                continue
            where = f"{rel}:{line}: {src} -> {dst}"
            if src not in rank and src != side:
                bad.append(f"{where} ({src} is not in layers.toml)")
            elif dst == side:
                if src not in TABLE["side_imported_by"]:
                    bad.append(f"{where} (only {TABLE['side_imported_by']} may import {side})")
            elif src == side:
                if dst not in TABLE["side_may_import"]:
                    bad.append(f"{where} ({side} may import only {TABLE['side_may_import']})")
            elif dst not in rank:
                bad.append(f"{where} ({dst} is not in layers.toml)")
            elif dst == TABLE["cli"] and src not in TABLE["cli_imported_by"]:
                bad.append(f"{where} (nothing imports the command line)")
            elif rank[dst] > rank[src]:
                bad.append(f"{where} (points down the table: {dst} is below {src})")
    return bad


def test_every_import_follows_the_layer_table():
    bad = violations()
    assert not bad, "imports that break src/procedura_brep/layers.toml:\n" + "\n".join(bad)


def test_the_checker_catches_an_upward_import(tmp_path):
    """A planted upward import (gates importing the agent, llm importing the kernel) is found."""
    pkg = tmp_path / "procedura_brep"
    for unit in ("gates", "llm", "agent", "kernel"):
        (pkg / unit).mkdir(parents=True)
        (pkg / unit / "__init__.py").write_text("")
    (pkg / "gates" / "x.py").write_text("def f():\n    from ..agent import plan\n")
    (pkg / "llm" / "y.py").write_text("from procedura_brep import kernel\n")
    (pkg / "agent" / "z.py").write_text("from ..gates import x\n")  # allowed: points up
    global ROOT
    saved, ROOT = ROOT, pkg
    try:
        bad = violations(pkg)
    finally:
        ROOT = saved
    assert len(bad) == 2, bad
    assert "gates -> agent" in bad[0] and "llm -> kernel" in bad[1]


def test_importing_the_providers_loads_no_cad_numeric_or_gl_module():
    code = ("import sys, procedura_brep.llm\n"
            "heavy = ('numpy', 'PIL', 'OCP', 'build123d', 'trimesh', 'moderngl', 'mujoco', 'scipy')\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in heavy\n"
            "             or m.startswith('procedura_brep.render')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_importing_program_modules_by_name_loads_no_build123d():
    """``from procedura_brep.program import caps`` loads the module, not build123d (the
    package's lazy names must not answer for its own submodules: once that cost the CLI's cold
    build 1.5-3 s of build123d and scikit-learn imports in the parent)."""
    code = ("import sys\n"
            "from procedura_brep.program import cache, cachekeys, caps, sandbox, splice, trust\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('build123d', 'sklearn')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def _module_imports(path: Path, package: list[str], root: Path) -> set[str]:
    """The ``procedura_brep`` modules ``path`` imports (lazy ones included), each resolved to a
    module file: ``from . import compose`` names the submodule ``compose``, not the package."""
    out: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                   and getattr(block.test, "id", getattr(block.test, "attr", "")) == "TYPE_CHECKING"
                   for stmt in block.body for n in ast.walk(stmt)}  # annotations only: no cycle
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            base = (package[:len(package) - node.level + 1] if node.level else [])
            mod = ".".join(base + ([node.module] if node.module else []))
            if not mod.startswith("procedura_brep"):
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                out.add(sub if _module_file(sub, root) else mod)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("procedura_brep")}
    return {m for m in (_owner(t, root) for t in out) if m}


def _module_file(dotted: str, root: Path) -> Path | None:
    if dotted == "procedura_brep":
        return root / "__init__.py"
    rel = Path(*dotted.split(".")[1:])
    for p in (root / rel.with_suffix(".py"), root / rel / "__init__.py"):
        if p.exists():
            return p
    return None


def _owner(dotted: str, root: Path) -> str | None:
    """The module that defines ``dotted`` (itself, or the nearest module above a name in it)."""
    while dotted and _module_file(dotted, root) is None:
        dotted = dotted.rpartition(".")[0]
    return dotted or None


def import_cycles(root: Path = ROOT) -> list[list[str]]:
    """The import cycles between the modules of the package (strongly connected groups of two or
    more), lazy imports included."""
    graph: dict[str, set[str]] = {}
    for path in root.rglob("*.py"):
        rel = path.relative_to(root.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if path.name == "__init__.py" else rel.parts)
        package = list(rel.parts[:-1])  # the package a relative import starts from
        graph[name] = _module_imports(path, package, root) - {name}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    """Issue 25.3: no two modules import each other, directly or round a loop, lazily or not
    (a module both sides need, or ``TYPE_CHECKING`` for annotations, unties one)."""
    assert import_cycles() == []


def test_the_cycle_check_sees_a_lazy_cycle(tmp_path):
    pkg = tmp_path / "procedura_brep" / "mates"
    pkg.mkdir(parents=True)
    (tmp_path / "procedura_brep" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .b import x\n")
    (pkg / "b.py").write_text("def x():\n    from . import a\n")
    assert import_cycles(tmp_path / "procedura_brep") == [["procedura_brep.mates.a", "procedura_brep.mates.b"]]
