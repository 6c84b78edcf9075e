"""Offscreen views: catalog, colours where parts project, legend, determinism, cache, close-ups."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from procedura_brep import kernel
from procedura_brep.errors import RangeError
from procedura_brep.program.model import CompiledMate, CompiledModel, CompiledPart
from procedura_brep.render import (
    VIEWS,
    fit_camera,
    parse_views,
    part_colors,
    render_images,
    render_to_dir,
    scene,
    views_status,
)
from procedura_brep.render.compose import BACKGROUND

# Three 40 mm cubes side by side along X (left_box, mid_box, right_box) on a plate.
BOXES = {"left_box": (-60.0, 0.0, 20.0), "mid_box": (0.0, 0.0, 20.0), "right_box": (60.0, 0.0, 20.0)}


def _trans(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


@pytest.fixture(scope="module")
def model() -> CompiledModel:
    from build123d import Box
    cube = kernel.write_brep(Box(40, 40, 40).wrapped)
    parts = [CompiledPart(name="plate", brep=kernel.write_brep(Box(200, 60, 4).wrapped),
                          placement=_trans(0, 0, -2), frames={"top": _trans(0, 0, 2)}, material="aluminium")]
    for name, c in BOXES.items():
        parts.append(CompiledPart(name=name, brep=cube, placement=_trans(*c),
                                  frames={"bottom": _trans(0, 0, -20)}, material="painted_steel"))
    mates = [CompiledMate(name=f"{n}_seat", type="seat_face", kind="static", child=n, child_frame="bottom",
                          parent="plate", parent_frame="top", nominal_name="box_w", nominal=40.0, fit={},
                          options={}, dof={}, world_frame=_trans(c[0], 0, 0)) for n, c in BOXES.items()]
    return CompiledModel(name="boxes", params={}, parts=parts, mates=mates)


def _nearest_part(pixel: np.ndarray, colors: dict[str, tuple[int, int, int]]) -> str:
    """The part whose palette colour has the closest chromaticity (shading only scales brightness)."""
    p = pixel.astype(float) / max(float(pixel.max()), 1.0)
    return min(colors, key=lambda n: np.linalg.norm(p - np.array(colors[n]) / max(colors[n])))


def test_catalog_has_the_twenty_named_views() -> None:
    assert len(VIEWS) == 20
    assert {"front", "back", "left", "right", "top", "bottom", "tilt_up", "tilt_down"} <= set(VIEWS)
    assert {f"{k}_{c}{s}" for k in ("iso",) for c in ("ne", "nw", "se", "sw") for s in ("", "_low")} <= set(VIEWS)
    np.testing.assert_allclose(VIEWS["front"].direction, [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(VIEWS["top"].direction, [0, 0, 1], atol=1e-12)
    se = VIEWS["iso_se"].direction
    assert se[0] > 0 and se[1] < 0 and se[2] > 0
    assert VIEWS["iso_se_low"].direction[2] < 0
    for v in VIEWS.values():
        assert abs(np.linalg.norm(v.direction) - 1) < 1e-12


def test_parse_views_rejects_unknown_and_counts() -> None:
    assert parse_views("iso_ne, front") == ["iso_ne", "front"]
    assert len(parse_views("all")) == 20
    assert len(parse_views(None)) == 12
    with pytest.raises(ValueError, match="iso_ne"):
        parse_views("isometric")
    with pytest.raises(RangeError):
        parse_views([])


def test_camera_fit_keeps_the_box_in_frame() -> None:
    lo, hi = np.array([-100.0, -20, 0]), np.array([100.0, 20, 50])
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    for v in VIEWS.values():
        px = fit_camera(v, lo, hi).project(corners, 100)
        assert px.min() >= -1e-6 and px.max() <= 100 + 1e-6, v.name


def test_part_colours_are_stable_and_distinct() -> None:
    names = [f"part_{i}" for i in range(30)]
    a = part_colors(names)
    assert a == part_colors(names) and len(set(a.values())) == 30


def test_adding_a_part_never_recolours_the_parts_before_it() -> None:
    """Issue 23.6: part colours changed between the renders of one staged run (the recorded robot
    arm's 28 commits recoloured earlier parts at 23 of them). The build order of that run:"""
    names = ("base_plate base_hub turntable shoulder_bracket upper_arm elbow forearm wrist "
             "gripper_palm finger_l finger_r base_servo shoulder_servo elbow_servo wrist_servo "
             "gripper_servo shoulder_cap elbow_cap wrist_cap plate_bolt_fl plate_bolt_fr "
             "plate_bolt_rl plate_bolt_rr bracket_bolt_fl bracket_bolt_fr bracket_bolt_rl "
             "bracket_bolt_rr power_button").split()
    seen: dict[str, tuple[int, int, int]] = {}
    for k in range(1, len(names) + 1):
        now = part_colors(names[:k])
        assert {n: now[n] for n in seen} == seen, names[k - 1]
        assert len(set(now.values())) == k
        seen = now


@pytest.mark.parametrize("mode", ["parts", "clay", "pbr"])
def test_images_are_not_blank(model: CompiledModel, mode: str) -> None:
    imgs = render_images(model, "iso_se,front", mode=mode, size=96)
    for img in imgs.values():
        a = np.asarray(img)
        assert a.shape == (96, 96, 3)
        fg = np.any(a != np.array(BACKGROUND[mode], np.uint8), axis=2)
        assert 0.05 < fg.mean() < 0.95
        assert a[fg].std() > 3  # shaded, not a flat silhouette


@pytest.mark.parametrize("view", ["front", "top", "iso_se"])
def test_each_part_colour_lands_where_the_part_projects(model: CompiledModel, view: str) -> None:
    size = 160
    img = np.asarray(render_images(model, [view], mode="parts", size=size)[view])
    colors = part_colors([p.name for p in model.parts])
    lo, hi = scene.bounds(model)
    cam = fit_camera(VIEWS[view], lo, hi)
    d = VIEWS[view].direction
    for name, c in BOXES.items():
        # the centre of the cube face that looks at the camera (for iso: the top-front-right corner
        # region is shared, so sample the visible top face centre)
        n = np.round(d) if view != "iso_se" else np.array([0, 0, 1.0])
        x, y = cam.project(np.array(c) + 20 * n, size)[0]
        assert _nearest_part(img[int(y), int(x)], colors) == name, (view, name)
    # the rightmost box lies right of the leftmost one in every non-mirrored view
    xs = [cam.project(np.array(BOXES[n]), size)[0, 0] for n in ("left_box", "right_box")]
    assert xs[0] < xs[1]


def test_identical_input_gives_identical_images(model: CompiledModel) -> None:
    a = render_images(model, "iso_nw,eye_se", mode="pbr", size=80)
    scene._MESHES.clear()
    b = render_images(model, "iso_nw,eye_se", mode="pbr", size=80)
    for k in a:
        assert np.array_equal(np.asarray(a[k]), np.asarray(b[k]))


@pytest.mark.parametrize("size", [80, 96])
def test_a_pbr_view_finished_on_the_gpu_is_the_composed_one_byte_for_byte(model: CompiledModel,
                                                                           size: int) -> None:
    """pbr views (the build's sheet.png) are box-filtered over the background on the GPU
    (Renderer.draw_finished): the bytes must be those compose.finish makes of the supersampled
    frames, edges and background included."""
    from procedura_brep.render import compose, gl
    verts = scene.vertex_array(model, part_colors([p.name for p in model.parts]))
    lo, hi = scene.bounds(model)
    cams = [fit_camera(VIEWS[v], lo, hi) for v in ("iso_se", "front", "top")]
    r = gl.renderer()
    composed = [compose.finish(f, "pbr") for f in r.draw(verts, cams, size, "pbr")]
    finished = r.draw_finished(verts, cams, size, "pbr", BACKGROUND["pbr"])
    for a, b in zip(composed, finished, strict=True):
        assert b.shape == (size, size, 3) and b.dtype == np.uint8
        assert np.array_equal(a, b)
        assert 0.05 < np.any(a != np.array(BACKGROUND["pbr"], np.uint8), axis=2).mean() < 0.95
    empty = r.draw_finished(verts[:0], cams[:1], size, "pbr", BACKGROUND["pbr"])[0]
    assert np.all(empty == np.array(BACKGROUND["pbr"], np.uint8))


def test_render_to_dir_sheet_legend_cache_and_staleness(model: CompiledModel, tmp_path) -> None:
    r = render_to_dir(model, tmp_path, views="iso_se,front,top", size=64, sheet=True)
    assert set(r.legend) == {p.name for p in model.parts}
    assert json.loads((tmp_path / "legend.json").read_text()) == r.legend
    assert sorted(r.rendered) == sorted(["iso_se", "front", "top", "sheet"]) and not r.cached
    sheet = Image.open(r.paths["sheet"])
    assert sheet.size[0] > 2 * 64 and sheet.size[1] > 2 * 64
    assert views_status(model, tmp_path).ok

    again = render_to_dir(model, tmp_path, views="iso_se,front,top", size=64, sheet=True)
    assert not again.rendered and sorted(again.cached) == sorted(r.rendered)

    moved = CompiledModel(name=model.name, params={}, mates=model.mates,
                          parts=[*model.parts[:-1], CompiledPart(**{**{k: v for k, v in model.parts[-1].__dict__.items()
                                                                       if k != "_shape"},
                                                                   "placement": _trans(70, 0, 20)})])
    status = views_status(moved, tmp_path)
    assert not status.ok and "parts_front.png" in status.stale
    r2 = render_to_dir(moved, tmp_path, views="front", size=64)
    assert r2.stale_before == ["front"] and r2.current
    assert "parts_front.png" in views_status(moved, tmp_path).current


def test_close_up_and_frames_overlay(model: CompiledModel, tmp_path) -> None:
    r = render_to_dir(model, tmp_path, views="front", size=96, close_up="mid_box_seat", sheet=True)
    shots = [k for k in r.paths if k.startswith("closeup:")]
    assert len(shots) == 4 and "closeup_sheet" in r.paths
    plain = np.asarray(render_images(model, ["front"], size=96)["front"])
    over = np.asarray(render_images(model, ["front"], size=96, frames_overlay=True)["front"])
    assert (plain != over).any(axis=2).sum() > 30
    with pytest.raises(ValueError, match="mid_box_seat"):
        render_images(model, ["front"], focus="no_such_thing")


def test_renders_beside_mujoco_egl(model: CompiledModel) -> None:
    import mujoco
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom type='box' size='1 1 1'/></worldbody></mujoco>")
    with mujoco.Renderer(m, 32, 32) as r:
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        r.update_scene(d)
        assert r.render().max() > 0
    img = np.asarray(render_images(model, ["front"], size=48)["front"])
    assert (img != np.array(BACKGROUND["parts"], np.uint8)).any()


def test_a_pbr_sheet_s_legend_shows_the_materials_and_views_say_where_they_look_from(model, tmp_path):
    """Issue 26.6: the PBR sheet's legend showed parts-mode swatches; views are labelled with the
    side their camera looks from."""
    from procedura_brep.render.api import legend_of
    from procedura_brep.render.views import caption
    parts = dict(legend_of(model))
    pbr = legend_of(model, "pbr")
    for label, rgb in pbr:
        name = label.split(" (")[0]
        m = model.material_of(model.part(name))
        assert label == f"{name} ({m.name})" and rgb == tuple(round(255 * c) for c in m.rgb)
        assert rgb != parts[name]
    assert caption("front") == "front (from -Y, ortho)"
