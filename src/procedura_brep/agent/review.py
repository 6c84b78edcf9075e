"""The one-direction review, enforced in code.

A second call may sharpen the plan: add parts, make descriptions and mates more precise. It may
not take anything away. :func:`enforce_review` merges the reviewed plan into the original under
these rules and logs every repair it makes:

- every original part survives with its name, in its original relative order (a dropped part is
  restored; a reordering is undone);
- a new part sitting where dropped original parts were (in the reviewed order, between the same
  surviving neighbours) is read as a rename (one dropped part) or a merge (several): the originals
  are restored and the new part is not admitted;
- any other new part is admitted only if it mates to a part of the plan, and it is inserted right
  after the part it attaches to (its first mate's partner), after new parts already attached there;
- a sharpened description or mate list is taken when its mates still point only to parts placed
  before it; otherwise the original mates are kept.
"""

from __future__ import annotations

from dataclasses import replace

from .plan import Plan, PlannedPart


def enforce_review(original: Plan, reviewed: Plan) -> tuple[Plan, list[str]]:
    """The reviewed plan, repaired to keep the one-direction rule; with the repairs made."""
    orig_names = original.names
    orig_set = set(orig_names)
    rev = list(reviewed.parts)
    rev_by_name = {p.name: p for p in rev}
    repairs: list[str] = []

    survivors = [p.name for p in rev if p.name in orig_set]
    dropped = [n for n in orig_names if n not in rev_by_name]
    if survivors != [n for n in orig_names if n in rev_by_name]:
        repairs.append("restored the original order of " + ", ".join(
            n for n, m in zip(survivors, [n for n in orig_names if n in rev_by_name]) if n != m))

    # new parts standing in the gap of dropped originals: renames / merges
    replaced: dict[str, list[str]] = {}
    for i, p in enumerate(rev):
        if p.name in orig_set:
            continue
        prev = next((q.name for q in reversed(rev[:i]) if q.name in orig_set), None)
        nxt = next((q.name for q in rev[i + 1:] if q.name in orig_set), None)
        lo = orig_names.index(prev) + 1 if prev else 0
        hi = orig_names.index(nxt) if nxt else len(orig_names)
        gap = [n for n in orig_names[lo:hi] if n in dropped and not any(n in v for v in replaced.values())]
        if gap:
            replaced[p.name] = gap
    for new, olds in replaced.items():
        kind = "rename" if len(olds) == 1 else "merge"
        repairs.append(f"reverted the {kind} of {', '.join(olds)} into {new}: restored "
                       f"{', '.join(olds)}, did not admit {new}")
    for n in dropped:
        if not any(n in v for v in replaced.values()):
            repairs.append(f"restored dropped part {n}")

    added = [p for p in rev if p.name not in orig_set and p.name not in replaced]
    out: list[PlannedPart] = []
    placed: set[str] = set()

    def attach(anchor: str) -> None:
        for p in added:
            if p.name in placed or not p.mates or p.mates[0].partner != anchor:
                continue
            keep = tuple(m for m in p.mates if m.partner in placed)
            if len(keep) < len(p.mates):
                repairs.append(f"new part {p.name}: dropped mates to parts not before it "
                               f"({', '.join(m.partner for m in p.mates if m.partner not in placed)})")
            out.append(replace(p, mates=keep))
            placed.add(p.name)
            attach(p.name)

    for name in orig_names:
        base = original.part(name)
        part = base
        if name in rev_by_name:
            sharp = rev_by_name[name]
            if all(m.partner in placed for m in sharp.mates) and (sharp.mates or not base.mates):
                part = sharp
            else:
                part = replace(sharp, mates=base.mates)
                repairs.append(f"part {name}: kept its original mates (the reviewed ones point to "
                               "parts not placed before it)")
        out.append(part)
        placed.add(name)
        attach(name)
    for p in added:
        if p.name not in placed:
            why = "it mates to nothing" if not p.mates else f"its partner {p.mates[0].partner} is not in the plan"
            repairs.append(f"did not admit new part {p.name}: {why}")
    return Plan(tuple(out), tuple(reviewed.notes)), repairs
