"""The articulation package sits below export: it never imports export, sim, render or agent
(this broke an import cycle: export imports articulation's value type)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "src" / "procedura_brep" / "articulation"
FORBIDDEN = ("export", "sim", "render", "agent", "cli")


def _imports(path: Path) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = "." * node.level + (node.module or "")
            out += [base] + [f"{base}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            out += [a.name for a in node.names]
    return out


def test_articulation_imports_no_lower_layer():
    bad = []
    for path in sorted(PKG.glob("*.py")):
        for name in _imports(path):
            parts = name.lstrip(".").split(".")
            top = parts[1] if parts[0] == "procedura_brep" and len(parts) > 1 else parts[0]
            if name.startswith("..") or name.startswith("procedura_brep."):
                if top in FORBIDDEN:
                    bad.append(f"{path.name}: {name}")
    assert not bad, bad


def test_importing_articulation_loads_no_exporter():
    code = ("import sys, procedura_brep.articulation as a, procedura_brep.articulation.wheels, "
            "procedura_brep.articulation.evidence; "
            "print(sorted(m for m in sys.modules if m.startswith('procedura_brep.export')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
