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
            "from procedura_brep.program import cache, caps, keys, sandbox, splice, trust\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('build123d', 'sklearn')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
