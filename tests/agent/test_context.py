"""The build context: an append-only layout that keeps consecutive requests' prefixes identical."""

from __future__ import annotations

import io
import json

from PIL import Image as PILImage

from procedura_brep.agent.context import (CommittedPart, build_request, part_slice, prefix_ratio,
                                          serialise)
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
