"""Deterministic order for the colour section of a STEP file written by OCCT.

``STEPCAFControl_Writer`` gathers the colour presentation of an assembly's parts (one
``MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION`` per part, each with its
``STYLED_ITEM`` and style entities) in a map keyed by shape, whose hash is the address of the
shape's ``TShape``; it adds them to the STEP model in that map's iteration order. Addresses
change from process to process, so the entity numbers of that section, and the bytes of the
file, did too. Nothing in the writer's API fixes that order, and the STEP model cannot be
reordered from Python (this OCP build's ``Interface_InterfaceModel.Number`` and the graph
tools find no entity passed in from Python), so the written text is canonicalised instead.

The rule: the presentation section is the file's tail, from the first presentation entity on
(nothing before it refers into it: checked). Its roots (entities no tail entity refers to) are
sorted by the entity numbers of the geometry they style, which come before the tail and are
fixed by the part order; the tail is then laid out again depth-first from the roots, following
references in field order, renumbered consecutively from where it started, and each record is
re-wrapped deterministically. Only numbers inside the tail change, so every reference stays
valid; the test re-reads the file through XCAF (names and colours). OCCT adds each part's
presentation root first, so the tail begins with a presentation entity; a file that breaks
these assumptions (a later OCCT) is left as written, with a warning.
"""

from __future__ import annotations

import logging
import re

from ..errors import KernelError

log = logging.getLogger(__name__)

#: Record types that open the presentation (colour) section OCCT appends after the geometry.
PRESENTATION_TYPES: tuple[str, ...] = (
    "MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION", "STYLED_ITEM",
    "OVER_RIDING_STYLED_ITEM", "PRESENTATION_LAYER_ASSIGNMENT", "DRAUGHTING_MODEL")
#: Physical lines of the rewritten records are wrapped after a comma beyond this column.
LINE_WIDTH = 72
#: Continuation lines are indented like OCCT's writer does.
INDENT = "    "

_REF = re.compile(r"#(\d+)")
_ID = re.compile(r"#(\d+)\s*=\s*")
#: A run of a record's text: a string (apostrophe to apostrophe, or to the end when left open)
#: or the text between strings.
_RUN = re.compile(r"'[^']*'?|[^']+")
_STRING = re.compile(r"'[^']*'")


def _split_records(data: str) -> list[tuple[str, int]]:
    """The records of a DATA section body: ``(#n = ... without the ;, offset after the ;)``.

    Semicolons inside STEP strings (apostrophe-quoted, ``''`` escapes) do not end a record: a
    piece between two semicolons that leaves an odd count of apostrophes open continues into
    the next (a ``''`` escape counts two, like an end and a new start).
    """
    out, start, pos, quotes = [], 0, 0, 0
    for piece in data.split(";")[:-1]:
        quotes += piece.count("'")
        pos += len(piece) + 1  # the offset after this piece's semicolon
        if quotes % 2 == 0:
            out.append((data[start:pos - 1].strip(), pos))
            start, quotes = pos, 0
    if data[start:].strip():
        raise KernelError("STEP DATA section ends inside a record")
    return out


def _outside_strings(body: str) -> list[tuple[str, bool]]:
    """``body`` cut into (text, is_string) runs (a string left open at the end is one too)."""
    if "'" not in body:  # a record without a string
        return [(body, False)]
    return [(m.group(), m.group().startswith("'")) for m in _RUN.finditer(body)]


def _refs(body: str) -> list[int]:
    """Entity numbers ``body`` refers to, in field order (not those inside strings)."""
    if "'" not in body:
        return [int(m) for m in _REF.findall(body)]
    return [int(m) for text, is_str in _outside_strings(body) if not is_str
            for m in _REF.findall(text)]


def _renumber(body: str, mapping: dict[int, int]) -> str:
    """``body`` with every reference ``#n`` outside strings replaced by ``#mapping[n]`` (when
    mapped) and line breaks outside strings removed."""
    out = []
    for text, is_str in _outside_strings(body):
        if is_str:
            out.append(text)
            continue
        text = re.sub(r"\s*\n\s*", "", text)
        out.append(_REF.sub(lambda m: f"#{mapping.get(int(m.group(1)), int(m.group(1)))}", text))
    return "".join(out)


def _wrap(line: str) -> str:
    """``line`` broken after commas outside strings once it passes :data:`LINE_WIDTH`."""
    out, col = [], 0
    for text, is_str in _outside_strings(line):
        if is_str:
            out.append(text)
            col += len(text)
            continue
        for ch in text:
            out.append(ch)
            col += 1
            if ch == "," and col > LINE_WIDTH:
                out.append("\n" + INDENT)
                col = len(INDENT)
    return "".join(out)


def canonical_step(text: str) -> str:
    """``text`` (a STEP file written by OCCT) with its presentation section in canonical order.

    Files without a presentation section come back unchanged; so does a file whose layout
    breaks the rule's assumptions (no DATA section, a presentation section that geometry refers
    into, a reference cycle), with a warning: the file is valid, only not reproducible.
    """
    try:
        return _canonical(text)
    except KernelError as exc:
        log.warning("STEP colour section left in OCCT's order (bytes may differ between "
                    "processes): %s", exc)
        return text


#: The start of a presentation record: at a line's start, ``#n =``, an optional ``(`` (a complex
#: entity), then one of :data:`PRESENTATION_TYPES` and its ``(``.
_OPENING = re.compile(r"^#\d+\s*=\s*[(\s]*(?:" + "|".join(PRESENTATION_TYPES) + r")\s*\(", re.M)


def _section_start(data: str) -> int | None:
    """The offset in ``data`` (a DATA section body) of the first presentation record, or None:
    the first match of :data:`_OPENING` outside strings (an even count of apostrophes before
    it) that starts a record (only blanks since the previous record's ``;``). Found in the text,
    so the geometry before it (nearly all of a large file) is never parsed record by record."""
    for m in _OPENING.finditer(data):
        at = m.start()
        if data.count("'", 0, at) % 2 == 0 and (not data[:at].strip() or data[:at].rstrip().endswith(";")):
            return at
    return None


def _canonical(text: str) -> str:
    """:func:`canonical_step`, raising :class:`KernelError` where it cannot apply the rule."""
    begin = text.find("\nDATA;\n")
    end = text.rfind("ENDSEC;")
    if begin < 0 or end < begin:
        raise KernelError("STEP text has no DATA section")
    body_start = begin + len("\nDATA;\n")
    data = text[body_start:end]
    start = _section_start(data)
    if start is None:
        return text
    tail: list[tuple[int, str]] = []
    for rec, _ in _split_records(data[start:]):
        m = _ID.match(rec)
        if m is None:
            raise KernelError(f"STEP record without an entity id: {rec[:40]!r}")
        tail.append((int(m.group(1)), rec[m.end():]))
    ids = [i for i, _ in tail]
    tail_ids = set(ids)
    head_text = data[:start]
    if {int(r) for r in _REF.findall(_STRING.sub("", head_text))} & tail_ids:  # ids and references
        raise KernelError("the STEP colour section is referenced by geometry entities; "
                          "cannot order it deterministically")
    bodies = dict(tail)
    refs = {i: _refs(b) for i, b in tail}
    referenced = {r for i in ids for r in refs[i] if r in tail_ids}

    def styled(root: int) -> tuple[int, ...]:
        seen, stack, found = set(), [root], set()
        while stack:
            i = stack.pop()
            if i not in seen:
                seen.add(i)
                for r in refs[i]:
                    (stack.append(r) if r in tail_ids else found.add(r))
        return tuple(sorted(found))

    roots = sorted((i for i in ids if i not in referenced),
                   key=lambda i: (styled(i), _REF.sub("#", bodies[i])))
    order: list[int] = []
    placed: set[int] = set()
    for root in roots:
        stack = [root]
        while stack:
            k = stack.pop()
            if k not in placed:
                placed.add(k)
                order.append(k)
                stack.extend(r for r in reversed(refs[k]) if r in tail_ids and r not in placed)
    if len(order) != len(ids):
        raise KernelError("the STEP colour section has a reference cycle; cannot order it")
    mapping = dict(zip(order, sorted(ids)))
    lines = [_wrap(f"#{mapping[i]} = {_renumber(bodies[i], mapping)};") for i in order]
    cut = body_start + start
    return text[:cut] + "\n".join(lines) + "\n" + text[end:]
