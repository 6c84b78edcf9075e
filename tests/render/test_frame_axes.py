"""Renders draw the chosen parts' origins and frames as axes at their world poses."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.program.model import CompiledMate, CompiledModel, CompiledPart
from procedura_brep.render import VIEWS, fit_camera, part_frames, render_images, render_to_dir, scene
from procedura_brep.render.api import FRAME_AXIS_FRACTION
from procedura_brep.render.compose import AXIS_COLORS

SIZE = 384
VIEW = "iso_se"


def _trans(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


@pytest.fixture(scope="module")
def model() -> CompiledModel:
    """A plate and a 40 mm block standing on it at x = 60, whose ``foot`` frame (at its bottom
    face) is turned 90 deg about Z, so its X axis points along world +Y."""
    from build123d import Box
    turned = _trans(0, 0, -20)
    turned[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    parts = [CompiledPart(name="plate", brep=kernel.write_brep(Box(200, 80, 4).wrapped),
                          placement=_trans(0, 0, -2), frames={"top": _trans(60, 0, 2)}),
             CompiledPart(name="block", brep=kernel.write_brep(Box(40, 40, 40).wrapped),
                          placement=_trans(60, 0, 20), frames={"foot": turned})]
    mate = CompiledMate(name="block_foot", type="seat_face", kind="static", child="block",
                        child_frame="foot", parent="plate", parent_frame="top", nominal_name="w",
                        nominal=40.0, fit={}, options={}, dof={}, world_frame=_trans(60, 0, 0))
    return CompiledModel(name="axes", params={}, parts=parts, mates=[mate])


def _axis_pixels(img: np.ndarray, camera, origin: np.ndarray, axis: np.ndarray, length: float,
                 color: tuple[int, int, int], half: int = 3) -> int:
    """Pixels of exactly ``color`` in a small window around the projected middle of an axis."""
    mid = camera.project(np.array([origin + axis * length / 2]), SIZE)[0]
    x, y = int(round(mid[0])), int(round(mid[1]))
    win = img[max(0, y - half):y + half + 1, max(0, x - half):x + half + 1]
    return int(np.all(win == np.array(color, np.uint8), axis=-1).sum())


def test_each_frame_of_the_chosen_part_is_drawn_as_coloured_axes(model):
    frames = part_frames(model, ["block"])
    assert [n for n, _ in frames] == ["block origin", "block.foot"]
    np.testing.assert_allclose(frames[1][1][:3, 3], [60, 0, 0])  # at its world pose
    np.testing.assert_allclose(frames[1][1][:3, 0], [0, 1, 0], atol=1e-12)  # X turned onto world +Y

    lo, hi = scene.bounds(model)
    camera = fit_camera(VIEWS[VIEW], lo, hi)
    length = FRAME_AXIS_FRACTION * float(np.linalg.norm(hi - lo))
    plain = np.asarray(render_images(model, [VIEW], size=SIZE)[VIEW])
    drawn = np.asarray(render_images(model, [VIEW], size=SIZE, frames_of=["block"])[VIEW])
    for name, pose in frames:
        for k, color in enumerate(AXIS_COLORS):  # X red, Y green, Z blue
            args = (camera, pose[:3, 3], pose[:3, k], length, color)
            assert _axis_pixels(drawn, *args) > 0, (name, "XYZ"[k])
            assert _axis_pixels(plain, *args) == 0, (name, "XYZ"[k])
    # the foot frame's X axis runs along world +Y: no red where an unturned X axis would be
    foot = frames[1][1]
    assert _axis_pixels(drawn, camera, foot[:3, 3], np.array([1.0, 0, 0]),
                        length, AXIS_COLORS[0], half=1) == 0


def test_an_unknown_part_is_refused_with_the_parts_listed(model):
    with pytest.raises(ValueError, match="no part named 'arm'.*parts: plate, block"):
        render_images(model, [VIEW], size=64, frames_of=["arm"])


def test_the_axes_are_part_of_the_cache_key(model, tmp_path):
    first = render_to_dir(model, tmp_path, views=VIEW, size=64)
    again = render_to_dir(model, tmp_path, views=VIEW, size=64, frames_of=["block"])
    assert first.rendered == [VIEW] and again.rendered == [VIEW] and not again.cached
    assert render_to_dir(model, tmp_path, views=VIEW, size=64, frames_of=["block"]).cached == [VIEW]


def test_the_render_command_takes_frames_of(tmp_path):
    from pathlib import Path

    from typer.testing import CliRunner

    from procedura_brep.cli import app
    lamp = Path(__file__).parents[1] / "program" / "lamp.py"
    runner = CliRunner()
    res = runner.invoke(app, ["render", str(lamp), "-o", str(tmp_path / "a"), "--views", VIEW,
                              "--size", "96", "--frames-of", "post,arm"])
    assert res.exit_code == 0, res.output
    manifest = (tmp_path / "a" / "renders.json").read_text()
    res = runner.invoke(app, ["render", str(lamp), "-o", str(tmp_path / "b"), "--views", VIEW,
                              "--size", "96"])
    assert res.exit_code == 0, res.output
    assert manifest != (tmp_path / "b" / "renders.json").read_text()  # the axes changed the key
    res = runner.invoke(app, ["render", str(lamp), "-o", str(tmp_path / "c"), "--frames-of", "lever"])
    assert res.exit_code == 2 and "lever" in res.output and "base, post, arm" in res.output
