"""The five-section program format: parse, locate, and report format errors by line.

A program is a header (docstring and ``from procedura_brep.program import *``) followed by five
sections in this order, each opened by a marker comment on its own line::

    # === params ===
    # === helpers ===
    # === parts ===
    # === frames ===
    # === assembly ===

The params section holds one assignment per line, ``name = <expression>  # unit, meaning``,
where the expression uses numbers, earlier params and ``math``.

One line numbering everywhere: Python's (lines end at ``\n``, ``\r\n`` or ``\r``). Characters
that ``str.splitlines`` also treats as line breaks but Python does not (vertical tab, form
feed, ``\x1c``-``\x1e``, NEL, the Unicode line and paragraph separators) would shift every
line number used by sections, edits and cache keys against the interpreter's, so a program
that contains one is refused with the line. A program longer than
``config.SANDBOX.source_bytes`` is refused before anything else reads it.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass, field

from ..config import SANDBOX
from ..errors import ProgramFormatError

SECTION_NAMES: tuple[str, ...] = ("params", "helpers", "parts", "frames", "assembly")
MARKER_RE = re.compile(r"#\s*===\s*([A-Za-z_]+)\s*===\s*")
#: Line breaks for ``str.splitlines`` that are not line breaks for Python.
ODD_BREAKS_RE = re.compile("[\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]")


def check_size(source: str, *, limit: int | None = None) -> None:
    """Refuse a program over the size cap (``config.SANDBOX.source_bytes``), naming the cap."""
    cap = SANDBOX.source_bytes if limit is None else limit
    size = len(source) if len(source) * 4 <= cap else len(source.encode("utf-8", "surrogatepass"))
    if size > cap:
        raise ProgramFormatError(f"the program is {size} bytes; programs are limited to {cap} bytes "
                                 f"(config.SANDBOX.source_bytes)")


def check_text(source: str, *, limit: int | None = None) -> None:
    """Refuse a program over the size cap or with a character that breaks line numbering.

    Raises:
        ProgramFormatError: naming the cap, or the line and the character.
    """
    check_size(source, limit=limit)
    m = ODD_BREAKS_RE.search(source)
    if m:
        line = source.count("\n", 0, m.start()) + 1
        raise ProgramFormatError(f"the character {m.group()!r} (a line break for some tools but "
                                 f"not for Python) is not allowed in a program; remove it",
                                 line=line)


def marker(name: str) -> str:
    """The canonical marker line of a section."""
    return f"# === {name} ==="


@dataclass
class Param:
    """One param line: name, expression text, 1-based line number, trailing comment."""

    name: str
    expr: str
    line: int
    comment: str


@dataclass
class Sections:
    """A parsed program: the marker line of each section and its params."""

    source: str
    starts: dict[str, int]  # section -> 1-based line of its marker
    params: dict[str, Param] = field(default_factory=dict)
    #: The module's syntax tree, parsed once here: the policy, the cache keys, the compiler and
    #: the splice read it instead of parsing the source again (four parses of a 40-part program
    #: were a tenth of a splice step).
    tree: ast.Module | None = field(default=None, repr=False, compare=False)

    def span(self, name: str) -> tuple[int, int]:
        """(first, last) 1-based body lines of a section (may be empty: first > last)."""
        i = SECTION_NAMES.index(name)
        first = self.starts[name] + 1
        last = (self.starts[SECTION_NAMES[i + 1]] - 1 if i + 1 < len(SECTION_NAMES)
                else len(self.source.splitlines()))
        return first, last

    def section_of(self, line: int) -> str | None:
        for name in reversed(SECTION_NAMES):
            if line > self.starts[name]:
                return name
        return None


def parse_sections(source: str) -> Sections:
    """Check the section markers and parse the params.

    Raises:
        ProgramFormatError: a section is missing, duplicated or out of order (with the line of
            the offending marker), the text is not Python, or a params line is not a simple
            ``name = expression`` assignment.
    """
    check_text(source)
    starts: dict[str, int] = {}
    order: list[str] = []
    for no, text in enumerate(source.splitlines(), start=1):
        m = MARKER_RE.fullmatch(text.strip())
        if not m:
            continue
        name = m.group(1).lower()
        if name not in SECTION_NAMES:
            raise ProgramFormatError(f"unknown section marker {name!r}; sections are "
                                     f"{', '.join(SECTION_NAMES)}", line=no)
        if name in starts:
            raise ProgramFormatError(f"section {name!r} appears twice (first at line "
                                     f"{starts[name]})", line=no)
        expected = SECTION_NAMES[len(order)]
        if name != expected:
            raise ProgramFormatError(f"section {name!r} is out of order: expected {expected!r} "
                                     f"here (order: {' -> '.join(SECTION_NAMES)})", line=no)
        starts[name] = no
        order.append(name)
    missing = [n for n in SECTION_NAMES if n not in starts]
    if missing:
        after = order[-1] if order else None
        where = f" after section {after!r} (line {starts[after]})" if after else ""
        raise ProgramFormatError(f"missing section marker(s) {', '.join(marker(n) for n in missing)}"
                                 f"{where}", line=starts[after] if after else 1)
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        raise ProgramFormatError(f"syntax error: {exc.msg}", line=exc.lineno) from None
    sec = Sections(source, starts, tree=tree)
    lines = source.splitlines()
    first, last = sec.span("params")
    for node in tree.body:
        if not (first <= node.lineno <= last):
            continue
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1
                and isinstance(node.targets[0], ast.Name)):
            raise ProgramFormatError("the params section holds only `name = value  # unit` lines",
                                     line=node.lineno)
        if node.end_lineno != node.lineno:
            raise ProgramFormatError("a param must fit on one line", line=node.lineno)
        name = node.targets[0].id
        if name in sec.params:
            raise ProgramFormatError(f"param {name!r} is assigned twice (first at line "
                                     f"{sec.params[name].line})", line=node.lineno)
        text = lines[node.lineno - 1]
        # one line: cut by UTF-8 byte offsets (ast.get_source_segment re-splits the whole
        # source on every call, quadratic in a long program)
        raw = text.encode("utf-8")
        expr = raw[node.value.col_offset:node.value.end_col_offset].decode("utf-8")
        tail = raw[node.value.end_col_offset:].decode("utf-8")
        comment = tail[tail.index("#"):] if "#" in tail else ""
        sec.params[name] = Param(name, expr, node.lineno, comment)
    return sec
