"""Program text builders for tests and benchmarks: N parts joined by mates, and part replies.

:func:`tower` is the synthetic program of ``benchmarks/incremental.py``: a tower of filleted,
bored blocks, each seated on the one below by a ``peg_socket`` and turned 15 deg about Z, so no
two blocks overlap and every block has exactly one mate partner below (and one above). Every
block publishes its ``top`` frame whether or not a block sits on it, so adding block ``n``
changes no frame of block ``n - 1``, only its mates.

:func:`tower_reply` is the five-block reply that adds the next block (what a model would send
in a staged build), for :func:`procedura_brep.program.splice.splice`.
"""

from __future__ import annotations

from collections.abc import Sequence

TOWER_PARAMS: tuple[str, ...] = (
    "block_w = 40.0  # mm, block side",
    "block_h = 12.0  # mm, block height",
    "peg_d = 8.0  # mm, the nominal of every block's peg_socket",
    "bore_d = 10.0  # mm, the bore through each block",
)
TOWER_HELPERS = '''def block(k):
    b = Box(block_w, block_w, block_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    b = fillet(b.edges().filter_by(Axis.Z), radius=3)
    return b - Pos(block_w / 4, 0, 0) * Cylinder(bore_d / 2 + 0.01 * (k % 5), block_h * 3)
'''


def program_text(*, doc: str, params: Sequence[str] = (), helpers: str = "",
                 parts: Sequence[str] = (), frames: Sequence[str] = (),
                 mates: Sequence[str] = ()) -> str:
    """Assemble a five-section program from its pieces (each a list of source texts)."""
    return (f'"""{doc}"""\nfrom procedura_brep.program import *\n\n'
            f"# === params ===\n" + "".join(p + "\n" for p in params)
            + "\n# === helpers ===\n" + (helpers.rstrip("\n") + "\n" if helpers else "")
            + "\n# === parts ===\n" + "\n".join(p.rstrip("\n") + "\n" for p in parts)
            + "\n# === frames ===\n" + "".join(f + "\n" for f in frames)
            + "\n# === assembly ===\n" + "".join(m + "\n" for m in mates))


def tower_part(i: int, *, description: str | None = None) -> str:
    """The ``@part`` function of block ``i`` (``p{i}``)."""
    desc = description if description is not None else f"block {i}"
    return (f'@part(detail="major", material="aluminium", description="{desc}")\n'
            f"def p{i}():\n    return block({i})\n")


def tower_frames(i: int) -> str:
    """Block ``i``'s frames: its foot and the top face the next block sits on."""
    return (f'frames("p{i}", foot=Location((0, 0, 0)), '
            f'top=Location((-8, 8, block_h), (0, 0, 15)))')


def tower_mate(i: int) -> str:
    """The mate that seats block ``i`` (``i >= 1``) on block ``i - 1``."""
    return (f'mate("p{i}.foot", "p{i - 1}.top", "peg_socket", nominal="peg_d", '
            f'fit="clearance", depth=5)')


def tower(n: int, *, helpers: str = "") -> str:
    """A tower of ``n`` blocks ``p0`` .. ``p{n-1}`` (``helpers``: extra helper source)."""
    if n < 1:
        raise ValueError(f"a tower needs at least 1 block, got n = {n}")
    return program_text(doc=f"Synthetic tower of {n} blocks (generated test program).",
                        params=TOWER_PARAMS, helpers=TOWER_HELPERS + helpers,
                        parts=[tower_part(i) for i in range(n)],
                        frames=[tower_frames(i) for i in range(n)],
                        mates=[tower_mate(i) for i in range(1, n)])


def reply_text(*, params: Sequence[str] = (), helpers: str = "", body: str,
               frames: Sequence[str] = (), mates: Sequence[str] = (), part: str = "") -> str:
    """A five-block part reply as a model would write it (headings and code fences)."""
    blocks = {"params": "\n".join(params), "helpers": helpers.rstrip("\n"),
              "body": body.rstrip("\n"), "frames": "\n".join(frames), "mates": "\n".join(mates)}
    out = [f"Here is part {part}." if part else "Here is the part."]
    for name, text in blocks.items():
        out += [f"## {name}", "```python", text or "# none", "```"]
    return "\n".join(out) + "\n"


def tower_reply(i: int) -> str:
    """The reply that adds block ``i`` (``i >= 1``) on top of a tower of ``i`` blocks; it
    repeats the params and the helper it uses, as a model would (the splice drops repeats)."""
    if i < 1:
        raise ValueError(f"block {i} has no block below it; replies add blocks i >= 1")
    return reply_text(part=f"p{i}", params=TOWER_PARAMS, helpers=TOWER_HELPERS,
                      body=tower_part(i), frames=[tower_frames(i)], mates=[tower_mate(i)])


def hinge_row(n: int) -> str:
    """A program of ``n`` parts (n odd: a base and (n - 1) / 2 post + flap hinges)."""
    k = max(1, (n - 1) // 2)
    pitch = 70.0
    rows = ['"""A row of hinges (synthetic benchmark program, hand-written generator)."""',
            "from procedura_brep.program import *", "", "# === params ===",
            f"pitch = {pitch}  # mm, hinge spacing", "post_w = 20.0  # mm", "post_h = 60.0  # mm",
            "peg_d = 8.0  # mm, post peg: nominal of the posts' peg_socket",
            "pin_d = 6.0  # mm, hinge pin: nominal of the flaps' revolute",
            f"base_l = {k * pitch + 40.0}  # mm", "", "# === helpers ===", "", "# === parts ===",
            '@part(detail="silhouette", material="aluminium", description="base plate")',
            "def base():",
            "    return Box(base_l, 60, 10, align=(Align.MIN, Align.CENTER, Align.MAX))", ""]
    frames = ['frames("base", ' + ", ".join(
        f"p{i}=Location(({20.0 + pitch / 2 + i * pitch}, 0, 0))" for i in range(k)) + ")"]
    mates = []
    for i in range(k):
        rows += [f'@part(detail="major", material="steel", description="post {i}")',
                 f"def post_{i}():",
                 "    return Box(post_w, post_w, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))", "",
                 f'@part(detail="major", material="aluminium", description="flap {i}")',
                 f"def flap_{i}():",
                 "    return Box(40, 4, 30, align=(Align.CENTER, Align.MIN, Align.MIN))", ""]
        frames += [f'frames("post_{i}", foot=Location((0, 0, 0)), '
                   f'head=Location((0, post_w / 2, post_h - 8), (-90, 0, 0)))',
                   f'frames("flap_{i}", pivot=Location((0, 0, 4), (-90, 0, 0)))']
        mates += [f'mate("post_{i}.foot", "base.p{i}", "peg_socket", nominal="peg_d", fit="location")',
                  f'mate("flap_{i}.pivot", "post_{i}.head", "revolute", nominal="pin_d", '
                  f'fit="clearance", limits=(-60, 60), effort=20.0)']
    return "\n".join(rows + ["# === frames ===", *frames, "", "# === assembly ===", *mates, ""])
