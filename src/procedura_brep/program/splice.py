"""The program splice: add one part, written as a five-block reply, to a compiling program.

The staged agent asks the model for one part per call. Its reply carries five blocks::

    ## params      new `name = value  # unit` lines (params it shares with the program may repeat)
    ## helpers     helper functions it needs (an identical copy of an existing helper is dropped)
    ## body        exactly one `@part(...)` function
    ## frames      the `frames("<part>", ...)` calls of this part
    ## mates       the `mate("<part>.<frame>", ...)` calls joining it to earlier parts

:func:`parse_reply` reads them tolerantly (code fences or not, stray prose around them, headings
or ``# === name ===`` markers, any case). :func:`splice` then inserts each block at its section
of the program, in plan order, and returns the new source with the helper renames it made and a
map from program lines back to reply lines (so a compile finding points into the reply).

Line numbers follow Python's own (``\\n``; a ``\\r\\n`` reply is normalised first).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from typing import TypeGuard, cast

from ..errors import ProgramFormatError
from .sections import SECTION_NAMES, Sections, marker, parse_sections

BLOCKS: tuple[str, ...] = ("params", "helpers", "body", "frames", "mates")
_ALIASES = {"param": "params", "parameters": "params", "helper": "helpers", "part": "body",
            "parts": "body", "frame": "frames", "mate": "mates", "assembly": "mates"}
_SECTION_OF = {"params": "params", "helpers": "helpers", "body": "parts", "frames": "frames",
               "mates": "assembly"}
# A block heading: "## params", "**Params:**", "PARAMS:", "# === params ===", "params block".
_HEAD_RE = re.compile(
    r"^\s*(?:#{1,6}\s*|\*\*|#\s*===\s*)?(?:block\s*\d*\s*[:.-]?\s*)?"
    r"(params?|parameters|helpers?|body|parts?|frames?|mates?|assembly)"
    r"(?:\s+block)?\s*(?:===)?\s*:?\s*(?:\*\*)?\s*:?\s*$", re.I)
_FENCE_RE = re.compile(r"^\s*(```|~~~)")
_EMPTY_RE = re.compile(r"^\s*(#\s*)?\(?(none|nothing|empty|n/?a|-)\)?\.?\s*$", re.I)


class SpliceError(ProgramFormatError):
    """A part reply cannot be spliced: a missing block, a clash, a malformed statement."""

    def __init__(self, message: str, *, block: str | None = None, line: int | None = None) -> None:
        self.block = block
        where = f"{block} block" + (f" line {line}" if line is not None else "") if block else None
        super().__init__(f"{where}: {message}" if where else message)


@dataclass(frozen=True)
class PartReply:
    """The five blocks of one part reply, each as plain Python text (possibly empty)."""

    params: str
    helpers: str
    body: str
    frames: str
    mates: str

    def block(self, name: str) -> str:
        text: str = getattr(self, name)
        return text

    def text(self) -> str:
        """The five blocks as a reply: a heading and one fenced python block each (``# none``
        for an empty one), the form :func:`parse_reply` reads back."""
        return reply_text({b: self.block(b) for b in BLOCKS})


def reply_text(blocks: Mapping[str, str]) -> str:
    """Five blocks (name -> code) as a reply, in order, ``# none`` for a missing or empty one."""
    return "\n".join(f"## {b}\n```python\n{blocks.get(b, '').strip() or '# none'}\n```" for b in BLOCKS)


@dataclass
class SpliceResult:
    """The new program and how the reply landed in it.

    Attributes:
        source: the new program text.
        part: the name of the part that was added.
        renames: helper renames, old name -> new name (a colliding helper of different code).
        dropped_params: params the reply repeated with the program's value (not added again).
        dropped_helpers: helpers identical to the program's (not added again).
        line_map: new-program line -> (block, line in that block) for every inserted line.
        inserted: block -> the text that went into the program (renamed, without repeats).
        changed_params: params whose value a replaced part changed in place.
    """

    source: str
    part: str
    renames: dict[str, str] = field(default_factory=dict)
    dropped_params: list[str] = field(default_factory=list)
    dropped_helpers: list[str] = field(default_factory=list)
    line_map: dict[int, tuple[str, int]] = field(default_factory=dict)
    inserted: dict[str, str] = field(default_factory=dict)
    changed_params: list[str] = field(default_factory=list)

    def as_reply(self) -> str:
        """The inserted blocks as a five-block reply (how the part now reads in the program)."""
        return reply_text(self.inserted)

    def reply_line(self, program_line: int) -> tuple[str, int] | None:
        """Where a program line came from in the reply (None: it was already in the program)."""
        return self.line_map.get(program_line)


def empty_program(description: str = "procedura-brep program.") -> str:
    """A program with a docstring, the API import and five empty sections."""
    doc = description.replace('"""', "'''").strip() or "procedura-brep program."
    body = "\n\n".join(marker(n) for n in SECTION_NAMES)
    return f'"""{doc}"""\nfrom procedura_brep.program import *\n\n{body}\n'


def parse_reply(text: str) -> PartReply:
    """Split a model's part reply into its five blocks.

    Accepts markdown headings or ``# === name ===`` markers, with or without code fences, in one
    fence or one fence per block, with prose between blocks (prose outside fences is dropped
    when the reply uses fences). ``none`` or an empty block means the block is empty.

    Raises:
        SpliceError: a block is missing or given twice (naming it).
    """
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    fenced = any(_FENCE_RE.match(t) for t in lines)
    found: dict[str, list[str]] = {}
    current: str | None = None
    inside = False
    for raw in lines:
        if _FENCE_RE.match(raw):
            inside = not inside
            continue
        head = _HEAD_RE.match(raw)
        if head and (inside or not raw.lstrip().startswith("#") or "===" in raw or raw.lstrip()[:2] == "##"
                     or not fenced):
            name = head.group(1).lower()
            name = _ALIASES.get(name, name)
            if name in found:
                raise SpliceError(f"the {name} block appears twice", block=name)
            found[name] = []
            current = name
            continue
        if current is None or (fenced and not inside):
            continue
        found[current].append(raw)
    missing = [b for b in BLOCKS if b not in found]
    if missing:
        raise SpliceError(f"missing block(s) {', '.join(missing)}; a part reply has five blocks: "
                          f"{', '.join(BLOCKS)} (write 'none' for an empty one)")
    blocks = {}
    for name in BLOCKS:
        body = [t for t in found[name]]
        while body and not body[-1].strip():
            body.pop()
        while body and not body[0].strip():
            body.pop(0)
        if len(body) == 1 and _EMPTY_RE.match(body[0]):
            body = []
        blocks[name] = _trim_prose("\n".join(body)) if not fenced else "\n".join(body)
    return PartReply(**blocks)


def _parses(text: str) -> bool:
    try:
        ast.parse(text)
    except SyntaxError:
        return False
    return True


def _trim_prose(text: str) -> str:
    """Without fences, prose may precede or follow the code: drop paragraphs at either end that
    read as sentences (no ``=``, ``(``, indentation or ``:`` line ends, and not Python). Code with
    a real syntax error is kept, so the error reaches the model instead of a silently lost line."""
    paras = re.split(r"\n\s*\n", text)

    def prose(p: str) -> bool:
        rows = p.split("\n")
        return (not _parses(p) and bool(re.match(r"[A-Za-z]", rows[0])) and "=" not in p
                and "(" not in p and not any(r[:1].isspace() or r.rstrip().endswith(":") for r in rows))

    while paras and prose(paras[0]):
        paras.pop(0)
    while paras and prose(paras[-1]):
        paras.pop()
    return "\n\n".join(paras)


def _parse_block(name: str, text: str) -> ast.Module:
    try:
        return ast.parse(text)
    except SyntaxError as exc:
        raise SpliceError(f"syntax error: {exc.msg}", block=name, line=exc.lineno) from None


def _norm(node: ast.AST) -> str:
    return ast.dump(node, annotate_fields=False, include_attributes=False)


def _string_arg(call: ast.AST) -> str | None:
    if (isinstance(call, ast.Expr) and isinstance(call.value, ast.Call) and call.value.args
            and isinstance(call.value.args[0], ast.Constant) and isinstance(call.value.args[0].value, str)):
        return call.value.args[0].value
    return None


def _call_name(stmt: ast.AST) -> str | None:
    if isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call) and isinstance(stmt.value.func, ast.Name):
        return stmt.value.func.id
    return None


def _owner(section: str, stmt: ast.stmt, mates: Mapping[str, str] | None = None) -> str | None:
    """The part a top-level statement of a section belongs to: a part's function, its
    ``frames(...)``, the ``mate(...)`` whose child it is, and a ``couple(...)`` whose driven mate
    is one of its mates (``mates``: mate name -> child part, :func:`mate_children`)."""
    if section == "parts":
        return stmt.name if isinstance(stmt, ast.FunctionDef) else None
    first = _string_arg(stmt)
    if first is None:
        return None
    if section == "assembly" and _call_name(stmt) == "couple":
        return (mates or {}).get(first)
    return first.split(".")[0] if section == "assembly" else first


def mate_children(stmts: list[ast.stmt]) -> dict[str, str]:
    """Mate name -> child part of the ``mate(...)`` calls among ``stmts`` (the name is the
    ``name=`` keyword, else ``"child.frame"`` with the dot as an underscore, as the compiler
    names it)."""
    out: dict[str, str] = {}
    for stmt in stmts:
        child = _string_arg(stmt)
        if _call_name(stmt) != "mate" or child is None:
            continue
        call = stmt.value  # type: ignore[attr-defined]  # an Expr of a Call: _string_arg checked
        named = [k.value.value for k in call.keywords if k.arg == "name"
                 and isinstance(k.value, ast.Constant) and isinstance(k.value.value, str)]
        out[named[0] if named else child.replace(".", "_")] = child.split(".")[0]
    return out


def _is_part_def(stmt: ast.stmt) -> TypeGuard[ast.FunctionDef]:
    return isinstance(stmt, ast.FunctionDef) and any(
        (isinstance(d, ast.Call) and isinstance(d.func, ast.Name) and d.func.id == "part")
        or (isinstance(d, ast.Name) and d.id == "part") for d in stmt.decorator_list)


@dataclass
class _Program:
    """The program's sections, top-level statements and names, parsed once."""

    lines: list[str]
    tree: ast.Module
    starts: dict[str, int]
    params: dict[str, ast.Assign]
    helpers: dict[str, ast.stmt]
    parts: list[str]

    @classmethod
    def read(cls, source: str) -> _Program:
        sec = parse_sections(source)
        tree = sec.tree or ast.parse(source)
        params: dict[str, ast.Assign] = {}
        helpers: dict[str, ast.stmt] = {}
        parts: list[str] = []
        for stmt in tree.body:
            where = sec.section_of(stmt.lineno)
            if where == "params" and isinstance(stmt, ast.Assign):
                params[stmt.targets[0].id] = stmt  # type: ignore[attr-defined]  # one Name: parse_sections checks
            elif where == "helpers" and isinstance(stmt, (ast.FunctionDef, ast.Assign)):
                names = [stmt.name] if isinstance(stmt, ast.FunctionDef) else [
                    t.id for t in stmt.targets if isinstance(t, ast.Name)]
                for n in names:
                    helpers[n] = stmt
            elif where == "parts" and _is_part_def(stmt):
                parts.append(stmt.name)
        return cls(source.split("\n"), tree, dict(sec.starts), params, helpers, parts)

    def section_end(self, section: str) -> int:
        """The last 1-based line of a section's body (the line before the next marker)."""
        i = SECTION_NAMES.index(section)
        if i + 1 < len(SECTION_NAMES):
            return self.starts[SECTION_NAMES[i + 1]] - 1
        return len(self.lines)

    def statements(self, section: str) -> list[ast.stmt]:
        lo, hi = self.starts[section], self.section_end(section)
        return [s for s in self.tree.body if lo < s.lineno <= hi]

    @property
    def mate_children(self) -> dict[str, str]:
        """Mate name -> child part of every mate of the program."""
        return mate_children(self.statements("assembly"))

    def insertion_line(self, section: str, before: set[str]) -> int:
        """The line after which a new part's statements go in ``section``: after the last
        statement owned by a part in ``before`` (the parts that precede it in plan order), or at
        the section's end when ``before`` is every part."""
        stmts = self.statements(section)
        owned = [s for s in stmts if _owner(section, s, self.mate_children) in before]
        if set(self.parts) <= before or not stmts:
            last = self.section_end(section)
            while last > self.starts[section] and not self.lines[last - 1].strip():
                last -= 1
            return last
        if owned:
            return max(s.end_lineno or s.lineno for s in owned)
        return self.starts[section]


def _rename_in(text: str, tree: ast.Module, renames: dict[str, str]) -> str:
    """Rename the helper names in ``renames`` wherever ``text`` defines or loads them."""
    if not renames:
        return text
    spots: list[tuple[int, int, int, str]] = []  # (line, col, length, new)
    lines = text.split("\n")
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in renames:
            spots.append((node.lineno, node.col_offset, len(node.id), renames[node.id]))
        elif isinstance(node, ast.FunctionDef) and node.name in renames:
            line = lines[node.lineno - 1]
            found = re.search(rf"\bdef\s+({re.escape(node.name)})\b", line)
            if found:
                spots.append((node.lineno, found.start(1), len(node.name), renames[node.name]))
    for lineno, col, length, new in sorted(spots, reverse=True):
        s = lines[lineno - 1]
        lines[lineno - 1] = s[:col] + new + s[col + length:]
    return "\n".join(lines)


def _free_name(name: str, taken: set[str]) -> str:
    k = 2
    while f"{name}_{k}" in taken:
        k += 1
    return f"{name}_{k}"


def replace_part(program: str, reply: PartReply | str) -> SpliceResult:
    """Replace an existing part with a new five-block reply for it, in the same place.

    The part's function, its ``frames(...)`` and its own mates (those whose child it is) are
    removed, then the reply is spliced back at the part's position in plan order. Mates of other
    parts onto this one stay, so its frames must keep their names. New params are added; the
    reply may change the value of a param that nothing else reads (its line is rewritten in
    place); a changed value of a param other parts read is a clash (``set_param`` changes it).

    Raises:
        SpliceError: as :func:`splice`, or the reply's part is not in the program.
    """
    blocks = parse_reply(reply) if isinstance(reply, str) else reply
    body = _parse_block("body", blocks.body).body
    name = body[0].name if body and isinstance(body[0], ast.FunctionDef) else None
    prog = _Program.read(program.replace("\r\n", "\n"))
    if name not in prog.parts:
        raise SpliceError(f"cannot replace part {name!r}: not in the program; parts: {', '.join(prog.parts)}",
                          block="body")
    drop: set[int] = set()
    mates = prog.mate_children
    for section in ("parts", "frames", "assembly"):
        for stmt in prog.statements(section):
            if _owner(section, stmt, mates) == name:
                first = min([stmt.lineno] + [d.lineno for d in getattr(stmt, "decorator_list", [])])
                drop.update(range(first, (stmt.end_lineno or stmt.lineno) + 1))
    kept = "\n".join(t for i, t in enumerate(prog.lines, start=1) if i not in drop)
    # what the rest of the program reads: names anywhere outside the param lines, the params'
    # own expressions, and the nominals (strings) of the other mates
    param_lines = {a.lineno for a in prog.params.values()}
    read: set[str] = set()
    for stmt in ast.parse(kept).body:
        if stmt.lineno in param_lines:
            value = cast(ast.Assign, stmt).value  # a param line: parse_sections checks it is one Assign
            read |= {n.id for n in ast.walk(value) if isinstance(n, ast.Name)}
            continue
        read |= {n.id for n in ast.walk(stmt) if isinstance(n, ast.Name)}
        read |= {n.value for n in ast.walk(stmt) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    k = prog.parts.index(name)
    return splice(kept, blocks, after=prog.parts[k - 1] if k else None, at_start=k == 0,
                  may_change=frozenset(set(prog.params) - read))


def splice(program: str, reply: PartReply | str, *, after: str | None = None,
           at_start: bool = False, may_change: frozenset[str] = frozenset()) -> SpliceResult:
    """Insert one part reply into ``program``.

    Args:
        program: the current program (it must parse; it need not have any part yet).
        reply: the five blocks, or the raw reply text (parsed with :func:`parse_reply`).
        after: the part that precedes the new one in plan order (default: the last part), so a
            part added by a re-plan lands at its place in every section.
        at_start: put the new part before every other part (it becomes the root).
        may_change: params whose value the reply may change in place (no other part reads them).

    Returns:
        The new source, the part's name, helper renames, dropped duplicates and the line map.

    Raises:
        SpliceError: a missing or malformed block, a param clash (both values named), a body
            that is not exactly one ``@part`` function, a part that already exists, frames or
            mates of another part, or an ``after`` that is not a part.
    """
    blocks = parse_reply(reply) if isinstance(reply, str) else reply
    prog = _Program.read(program.replace("\r\n", "\n"))
    trees = {b: _parse_block(b, blocks.block(b)) for b in BLOCKS}
    part = _part_function(trees, prog, after)
    name = part.name
    before = (set() if at_start else
              set(prog.parts if after is None else prog.parts[:prog.parts.index(after) + 1]))
    params = _merge_params(trees, prog, blocks, may_change)
    renames, keep_helpers, dropped_helpers = _merge_helpers(trees, prog, name)
    _check_owned(trees, name, {**prog.mate_children, **mate_children(trees["mates"].body)})
    texts = _block_texts(blocks, trees, params.keep, keep_helpers, renames, part)
    source = _insert(prog, texts, before, params.updates)
    try:
        sec = parse_sections(source)
    except ProgramFormatError as exc:
        raise SpliceError(f"the spliced program does not parse: {exc}") from None
    inserted = {b: "\n".join(t for t, _ in texts[b]).strip("\n") for b in BLOCKS}
    return SpliceResult(source, name, renames, params.dropped, dropped_helpers,
                        _line_map(source, sec, texts), inserted, params.changed)


def _part_function(trees: dict[str, ast.Module], prog: _Program, after: str | None) -> ast.FunctionDef:
    """The body block's one ``@part`` function (a new part; ``after`` must be a part)."""
    body = trees["body"].body
    defs = [s for s in body if isinstance(s, ast.FunctionDef)]
    if len(body) != 1 or len(defs) != 1 or not _is_part_def(defs[0]):
        raise SpliceError("must hold exactly one function decorated with @part(...), and nothing else",
                          block="body")
    if defs[0].name in prog.parts:
        raise SpliceError(f"part {defs[0].name!r} is already in the program", block="body", line=defs[0].lineno)
    if after is not None and after not in prog.parts:
        raise SpliceError(f"cannot insert after {after!r}: not a part; parts: {', '.join(prog.parts) or 'none'}")
    return defs[0]


@dataclass
class _Params:
    """The params block against the program: what is kept, dropped, changed in place."""

    keep: list[ast.stmt] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)
    updates: dict[int, str] = field(default_factory=dict)  # program line -> new param line


def _merge_params(trees: dict[str, ast.Module], prog: _Program, blocks: PartReply,
                  may_change: AbstractSet[str]) -> _Params:
    """New params appended, repeats with the same expression dropped, clashes refused (a param
    in ``may_change`` is changed in place)."""
    out = _Params()
    for stmt in trees["params"].body:
        if not (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1
                and isinstance(stmt.targets[0], ast.Name)):
            raise SpliceError("holds only `name = value  # unit` lines", block="params", line=stmt.lineno)
        pname = stmt.targets[0].id
        if pname in prog.params:
            old = prog.params[pname]
            if _norm(old.value) != _norm(stmt.value) and pname in may_change:
                out.updates[old.lineno] = blocks.params.split("\n")[stmt.lineno - 1]
                out.changed.append(pname)
                continue
            if _norm(old.value) != _norm(stmt.value):
                raise SpliceError(
                    f"param {pname} = {ast.unparse(stmt.value)} clashes with the program's "
                    f"{pname} = {ast.unparse(old.value)} (line {old.lineno}); reuse it or pick a new name",
                    block="params", line=stmt.lineno)
            out.dropped.append(pname)
            continue
        if pname in prog.helpers or pname in prog.parts:
            raise SpliceError(f"param {pname} has the name of an existing helper or part",
                              block="params", line=stmt.lineno)
        out.keep.append(stmt)
    return out


def _merge_helpers(trees: dict[str, ast.Module], prog: _Program,
                   name: str) -> tuple[dict[str, str], list[ast.stmt], list[str]]:
    """(renames, helpers kept, helpers dropped): identical copies dropped, the same name with
    other code renamed in the new blocks."""
    taken = set(prog.params) | set(prog.helpers) | set(prog.parts) | {name}
    renames: dict[str, str] = {}
    keep: list[ast.stmt] = []
    dropped: list[str] = []
    new_names: set[str] = set()
    for stmt in trees["helpers"].body:
        if isinstance(stmt, ast.FunctionDef):
            hname = stmt.name
        elif isinstance(stmt, ast.Assign) and all(isinstance(t, ast.Name) for t in stmt.targets):
            hname = cast(ast.Name, stmt.targets[0]).id  # all Names: checked above
        else:
            raise SpliceError("holds only function definitions and simple constants",
                              block="helpers", line=stmt.lineno)
        if hname in new_names:
            raise SpliceError(f"helper {hname} is defined twice", block="helpers", line=stmt.lineno)
        new_names.add(hname)
        if hname in prog.helpers and _norm(prog.helpers[hname]) == _norm(stmt):
            dropped.append(hname)
            continue
        if hname in taken:
            renames[hname] = _free_name(hname, taken | new_names)
            taken.add(renames[hname])
        keep.append(stmt)
    return renames, keep, dropped


def _check_owned(trees: dict[str, ast.Module], name: str, mates: Mapping[str, str]) -> None:
    """The frames block holds only ``frames(...)`` calls of part ``name``, the mates block only
    its ``mate(...)`` calls and ``couple(...)`` calls whose driven mate is one of its mates
    (``mates``: mate name -> child, the program's and the block's), and it publishes at least
    one frame."""
    for section, block in (("frames", "frames"), ("assembly", "mates")):
        for stmt in trees[block].body:
            call = _call_name(stmt)
            if call not in (("frames",) if block == "frames" else ("mate", "couple")):
                raise SpliceError("holds only frames(...) calls" if block == "frames" else
                                  "holds only mate(...) and couple(...) calls",
                                  block=block, line=stmt.lineno)
            owner = _owner(section, stmt, mates)
            if call == "couple" and owner != name:
                driven = _string_arg(stmt)
                raise SpliceError(f"couple({driven!r}, ...) must follow a mate of part {name!r} (the "
                                  f"driven mate is the part's own: {name}_<frame> or its name=); "
                                  f"{driven!r} is " + (f"a mate of {owner!r}" if owner else "no mate"),
                                  block=block, line=stmt.lineno)
            if owner != name:
                raise SpliceError(f"{'frames' if block == 'frames' else 'mates'} of {owner!r} do not belong "
                                  f"to part {name!r}", block=block, line=stmt.lineno)
    if not trees["frames"].body:
        raise SpliceError(f"part {name!r} publishes no frames: add frames({name!r}, ...)", block="frames")


def _block_texts(blocks: PartReply, trees: dict[str, ast.Module], keep_params: list[ast.stmt],
                 keep_helpers: list[ast.stmt], renames: dict[str, str],
                 part: ast.FunctionDef) -> dict[str, list[tuple[str, int]]]:
    """Each block's lines to insert, with their line in the block (0: an added blank line):
    the renames applied, only the kept params and helpers, the body from its decorator."""
    texts: dict[str, list[tuple[str, int]]] = {}
    for b in BLOCKS:
        src = blocks.block(b)
        keep = {"params": keep_params, "helpers": keep_helpers}.get(b)
        text = _rename_in(src, trees[b], renames)
        block_lines = text.split("\n") if text else []
        if keep is None:
            texts[b] = [(t, i) for i, t in enumerate(block_lines, start=1)]
            continue
        chosen: list[tuple[str, int]] = []
        for stmt in keep:
            first = min([stmt.lineno] + [d.lineno for d in getattr(stmt, "decorator_list", [])])
            chosen += [(block_lines[i - 1], i) for i in range(first, (stmt.end_lineno or stmt.lineno) + 1)]
            if b == "helpers":
                chosen += [("", 0), ("", 0)]
        texts[b] = chosen
    body_first = min([part.lineno] + [d.lineno for d in part.decorator_list])
    texts["body"] = [(t, i) for t, i in texts["body"] if i >= body_first]
    return texts


def _insert(prog: _Program, texts: dict[str, list[tuple[str, int]]], before: set[str],
            updates: dict[int, str]) -> str:
    """The program with the blocks inserted, each in its section after the parts in
    ``before`` (params and helpers always at the end), from the bottom of the file up so
    earlier insertion lines stay valid; ``updates`` replaces param lines in place."""
    inserts: list[tuple[int, str, list[tuple[str, int]]]] = []
    for b in BLOCKS:
        rows = texts[b]
        if not rows:
            continue
        section = _SECTION_OF[b]
        if b in ("params", "helpers"):
            at = prog.insertion_line(section, set(prog.parts))  # shared: always at the end
        else:
            at = prog.insertion_line(section, before)
        if b in ("helpers", "body"):  # functions: two blank lines before, one after
            while rows and not rows[-1][0].strip():
                rows = rows[:-1]
            lead = [("", 0), ("", 0)] if at > prog.starts[section] else []
            rows = [*lead, *rows, ("", 0)]
        inserts.append((at, b, rows))
    lines = list(prog.lines)
    for lineno, text in updates.items():
        lines[lineno - 1] = text
    for at, _block, rows in sorted(inserts, key=lambda x: x[0], reverse=True):
        lines[at:at] = [t for t, _ in rows]
    return re.sub(r"\n{4,}", "\n\n\n", "\n".join(lines))


def _line_map(source: str, sec: Sections, texts: dict[str, list[tuple[str, int]]]) -> dict[int, tuple[str, int]]:
    """Find each inserted block's lines in the new source (``sec``: its sections), in order,
    section by section."""
    lines = source.split("\n")
    out: dict[int, tuple[str, int]] = {}
    for b in BLOCKS:
        rows = [(t, i) for t, i in texts[b] if i and t.strip()]
        if not rows:
            continue
        first, last = sec.span(_SECTION_OF[b])
        # the block's rows appear as one contiguous run (blank lines aside) inside its section
        for start in range(first, last + 1):
            k, ln = 0, start
            hits: dict[int, tuple[str, int]] = {}
            while k < len(rows) and ln <= last:
                if lines[ln - 1] == rows[k][0]:
                    hits[ln] = (b, rows[k][1])
                    k += 1
                elif lines[ln - 1].strip():
                    break
                ln += 1
            if k == len(rows):
                out.update(hits)
                break
    return out


def program_parts(source: str) -> list[str]:
    """The program's part names, in order."""
    return list(_Program.read(source.replace("\r\n", "\n")).parts)


def param_readers(source: str) -> dict[str, set[str]]:
    """Which parts read each param: through their function, the helpers it calls (transitively),
    their frames, their mates (options and nominals), or params derived from it."""
    prog = _Program.read(source.replace("\r\n", "\n"))

    def names(node: ast.AST) -> set[str]:
        out = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
        return out | {n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)}

    reads: dict[str, set[str]] = {p: set() for p in prog.parts}
    mates = prog.mate_children
    for section in ("parts", "frames", "assembly"):
        for stmt in prog.statements(section):
            owner = _owner(section, stmt, mates)
            if owner in reads:
                reads[owner] |= names(stmt)
    for seen in reads.values():
        todo = [n for n in seen if n in prog.helpers or n in prog.params]
        while todo:
            n = todo.pop()
            node = prog.helpers.get(n) or prog.params[n].value
            for m in names(node) - seen:
                seen.add(m)
                if m in prog.helpers or m in prog.params:
                    todo.append(m)
    return {p: {part for part, seen in reads.items() if p in seen} for p in prog.params}
