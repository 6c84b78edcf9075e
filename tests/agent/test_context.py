"""The build context: an append-only layout that keeps consecutive requests' prefixes identical."""

from __future__ import annotations

import io
import json

from PIL import Image as PILImage

from procedura_brep.agent.context import CommittedPart, build_request, part_slice, prefix_ratio, serialise
from procedura_brep.agent.plan import parse_plan
from procedura_brep.llm import Image, Message


def png(colour) -> Image:
    buf = io.BytesIO()
    PILImage.new("RGB", (8, 8), colour).save(buf, format="PNG")
    return Image(buf.getvalue(), "v")


PLAN = parse_plan(json.dumps({"parts": [
    {"name": "chassis", "detail": "silhouette", "description": "600 x 400 x 120 mm frame, the root", "mates": []},
    *[{"name": f"wheel_{i}", "detail": "major", "description": f"160 mm wheel number {i}, axle along Y",
       "mates": [{"partner": "chassis", "type": "revolute", "nominal": "axle_d"}]} for i in range(8)],
    {"name": "mast", "detail": "major", "description": "300 mm mast on the chassis top",
     "mates": [{"partner": "chassis", "type": "peg_socket", "nominal": "mast_d"}]}]}))
SYSTEM = "You write one part of a procedura-brep program per call.\n" + "reference text. " * 600


def requests():
    committed: list[CommittedPart] = []
    out = []
    for k, part in enumerate(PLAN.parts):
        views = [png((k * 20, 0, 0)), png((0, k * 20, 0))] if k else []
        out.append(build_request(step=k, system=SYSTEM, prompt="a rover", plan=PLAN, header="# header",
                                 committed=committed, part=part, views=views))
        committed = [*committed, CommittedPart(part.name, f"@part()\ndef {part.name}():\n" + "    x = 1\n" * 60)]
    return out


def test_each_request_starts_with_the_whole_previous_request_but_its_tail():
    reqs = requests()
    for prev, cur in zip(reqs, reqs[1:]):
        a, b = serialise(prev), serialise(cur)
        head = a[:a.rindex("\n<user>\n")]  # everything before the previous call's slice + renders
        assert b.startswith(head)
        assert prefix_ratio(prev, cur) >= len(head) / len(b) - 1e-12


def test_prefix_ratio_over_a_ten_part_build():
    reqs = requests()
    ratios = [prefix_ratio(a, b) for a, b in zip(reqs, reqs[1:])]
    assert min(ratios) >= 0.8, ratios


def test_retries_continue_the_same_conversation():
    reqs = requests()
    first = reqs[3]
    retry = build_request(step=3, system=SYSTEM, prompt="a rover", plan=PLAN, header="# header",
                          committed=[CommittedPart(p.name, "x") for p in PLAN.parts[:3]], part=PLAN.parts[3],
                          history=[Message.assistant("bad reply"), Message.user("findings: ...")])
    assert len(retry.messages) == len(first.messages) + 2


def test_part_slice_names_mates_children_and_what_is_left():
    root = part_slice(PLAN, PLAN.parts[0])
    assert "Write part 1 of 10: chassis" in root and "It is the root" in root
    assert "wheel_0 (revolute)" in root and "mast (peg_socket)" in root
    last = part_slice(PLAN, PLAN.parts[-1])
    assert "- to chassis: peg_socket, nominal mast_d" in last and "Still to come" not in last


def test_views_are_named_with_the_side_each_camera_looks_from():
    """Issue 23.6 / 26: the model and the critic are told which view each image is, and that
    "front" looks from -Y."""
    from procedura_brep.agent.refine import _named

    def png() -> bytes:
        buf = io.BytesIO()
        PILImage.new("RGB", (4, 4)).save(buf, format="PNG")
        return buf.getvalue()

    views = [Image(png(), "front"), Image(png(), "iso_se")]
    assert _named(views) == ", in order: front (from -Y, ortho), iso_se (from +X-Y+Z, ortho)"
    assert _named([Image(png(), "front"), Image(png(), "")]) == ""  # an unnamed image: no claim


def _blocks(name: str, body_lines: int) -> str:
    body = "\n".join([f'@part(detail="major", description="{name}")', f"def {name}():"]
                     + [f"    x{i} = Box({i + 1}, 1, 1)" for i in range(body_lines)] + ["    return x0"])
    return (f"## params\n```python\n{name}_d = 10.0  # mm\n```\n## helpers\n```python\n# none\n```\n"
            f"## body\n```python\n{body}\n```\n## frames\n```python\nframes(\"{name}\", top=Location((0, 0, 1)))\n```\n"
            f"## mates\n```python\n# none\n```")


def test_the_log_cuts_bodies_and_the_tail_shows_the_partners_and_a_sibling_whole():
    """Issue 23.6: requests grew by every body written so far. The log keeps each part's params,
    frames and mates; the bodies the new part needs (its partners', a mirror sibling's) come
    whole with its task."""
    committed = [CommittedPart(p.name, _blocks(p.name, 40)) for p in PLAN.parts[:5]]
    req = build_request(step=5, system=SYSTEM, prompt="a rover", plan=PLAN, header="# header",
                        committed=committed, part=PLAN.parts[5])  # wheel_4, mated to the chassis
    log, tail = req.messages[1].text, req.messages[2].text
    assert "x39 = Box(40" not in log and log.count("body of 41 lines, cut here") == 5
    assert "wheel_0_d = 10.0" in log and 'frames("wheel_2", top=' in log  # the rest stays whole
    assert "### chassis" in tail and "def chassis():\n    x0 = Box(1, 1, 1)" in tail  # its partner
    assert "### wheel_3" in tail and "### wheel_0" not in tail  # the latest sibling only
    assert "x39 = Box(40" in tail


def test_a_request_grows_by_a_part_s_interface_not_its_body():
    sizes = []
    for n in (2, 9):
        committed = [CommittedPart(p.name, _blocks(p.name, 100)) for p in PLAN.parts[:n]]
        req = build_request(step=n, system=SYSTEM, prompt="a rover", plan=PLAN, header="# header",
                            committed=committed, part=PLAN.parts[-1])  # the mast: chassis partner
        sizes.append(len(serialise(req)))
    whole_body = len(_blocks("wheel_0", 100)) - len(_blocks("wheel_0", 0))
    assert (sizes[1] - sizes[0]) / 7 < 0.25 * whole_body, sizes
