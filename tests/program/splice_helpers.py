"""Cut a whole program into the per-part five-block replies a staged build would receive."""

from __future__ import annotations

import ast

from procedura_brep.program.sections import parse_sections


def _names(node: ast.AST) -> set[str]:
    out = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
    out |= {n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    return out


def part_replies(source: str) -> list[str]:
    """One reply text per part, in the program's order: each carries every param and helper its
    part needs (so later replies repeat shared ones, as a model would)."""
    sec = parse_sections(source)
    lines = source.split("\n")
    tree = ast.parse(source)

    def text(stmt: ast.stmt) -> str:
        first = min([stmt.lineno] + [d.lineno for d in getattr(stmt, "decorator_list", [])])
        return "\n".join(lines[first - 1:stmt.end_lineno])

    params: dict[str, ast.stmt] = {}
    helpers: dict[str, ast.stmt] = {}
    parts: dict[str, ast.stmt] = {}
    frames: dict[str, list[ast.stmt]] = {}
    mates: dict[str, list[ast.stmt]] = {}
    for stmt in tree.body:
        where = sec.section_of(stmt.lineno)
        if where == "params":
            params[stmt.targets[0].id] = stmt
        elif where == "helpers":
            helpers[stmt.name] = stmt
        elif where == "parts":
            parts[stmt.name] = stmt
        elif where == "frames":
            frames.setdefault(stmt.value.args[0].value, []).append(stmt)
        elif where == "assembly":
            mates.setdefault(stmt.value.args[0].value.split(".")[0], []).append(stmt)

    replies = []
    for name, fn in parts.items():
        own = [fn, *frames.get(name, []), *mates.get(name, [])]
        need: set[str] = set().union(*(_names(s) for s in own))
        grew = True
        while grew:  # close over helpers and param expressions
            more = set().union(*(_names(helpers[n]) for n in need if n in helpers),
                               *(_names(params[n].value) for n in need if n in params))
            grew = not more <= need
            need |= more
        blocks = {
            "params": [text(s) for n, s in params.items() if n in need],
            "helpers": [text(s) for n, s in helpers.items() if n in need],
            "body": [text(fn)],
            "frames": [text(s) for s in frames.get(name, [])],
            "mates": [text(s) for s in mates.get(name, [])],
        }
        out = [f"Here is part {name}."]
        for b, rows in blocks.items():
            joined = "\n\n".join(rows) if b == "helpers" else "\n".join(rows)
            out += [f"## {b}", "```python", joined or "# none", "```"]
        replies.append("\n".join(out))
    return replies
