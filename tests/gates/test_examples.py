"""Every complete program example a person or a model is shown compiles and passes every gate.

Examples are the fenced ``python`` blocks of README.md and docs/*.md, and the ``::`` literal
blocks of every docstring under ``src/procedura_brep`` (the program API's docstrings are the
text shown to the model), that hold a whole program (the import line and the assembly marker).
A block with an elided line (``...``) is a fragment, not a program, and is skipped.
"""

from __future__ import annotations

import ast
import re
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
IMPORT = "from procedura_brep.program import *"
MARKER = "# === assembly ==="


def _complete(text: str) -> bool:
    return IMPORT in text and MARKER in text and not re.search(r"^\s*\.\.\.\s*$", text, re.MULTILINE)


def markdown_examples(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    return [b for b in re.findall(r"```python\n(.*?)```", text, re.DOTALL) if _complete(b)]


def _literal_blocks(doc: str) -> list[str]:
    """The indented blocks that follow a line ending in ``::`` (reST literal blocks)."""
    lines = doc.splitlines()
    out = []
    i = 0
    while i < len(lines):
        if lines[i].rstrip().endswith("::"):
            j = i + 1
            while j < len(lines) and not lines[j].strip():
                j += 1
            block = []
            while j < len(lines) and (not lines[j].strip() or lines[j].startswith((" ", "\t"))):
                block.append(lines[j])
                j += 1
            out.append(textwrap.dedent("\n".join(block)).strip() + "\n")
            i = j
        else:
            i += 1
    return out


def docstring_examples(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = [ast.get_docstring(n, clean=True) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))]
    return [b for d in docs if d for b in _literal_blocks(d) if _complete(b)]


def all_examples() -> list[tuple[str, str]]:
    out = []
    for md in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        if md.exists():
            out += [(f"{md.relative_to(ROOT)}#{k}", b) for k, b in enumerate(markdown_examples(md))]
    for py in sorted((ROOT / "src" / "procedura_brep").rglob("*.py")):
        out += [(f"{py.relative_to(ROOT)}#{k}", b) for k, b in enumerate(docstring_examples(py))]
    return out


EXAMPLES = all_examples()


def test_the_shown_examples_are_found():
    names = [n.split("#")[0] for n, _ in EXAMPLES]
    assert "docs/program-format.md" in names
    assert "src/procedura_brep/program/api.py" in names


def test_extractor_skips_fragments_and_reads_docstrings():
    frag = f"{IMPORT}\n# === params ===\n...\n{MARKER}\n"
    assert not _complete(frag)
    doc = f"Example::\n\n    {IMPORT}\n\n    {MARKER}\n    mate()\n\nAfter."
    assert _literal_blocks(doc) == [f"{IMPORT}\n\n{MARKER}\nmate()\n"]


@pytest.mark.parametrize("name,source", EXAMPLES, ids=[n for n, _ in EXAMPLES])
def test_example_passes_every_gate(name: str, source: str, worker):
    from procedura_brep.gates import check_model
    from procedura_brep.program import compile_source

    model = compile_source(source, name="example", worker=worker)
    report = check_model(model, source)
    assert report.passed, f"{name}:\n{report.feedback}"
