"""Public entry points: render views to images in memory, or to a directory with a cache."""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from ..errors import RangeError
from ..program.model import CompiledModel
from ..text import did_you_mean
from . import compose, scene
from .cache import Manifest, geometry_key, image_key
from .gl import Mode, renderer
from .palette import RGB, hex_color, part_colors
from .views import VIEWS, fit_camera, parse_views

log = logging.getLogger(__name__)

MODES: tuple[str, ...] = ("parts", "clay", "pbr")
SIZE_RANGE: tuple[int, int] = (32, 4096)
"""Allowed image side in pixels."""
FRAME_AXIS_FRACTION: float = 0.06
"""Mate-frame overlay axes are this fraction of the model's bounding-box diagonal."""
CLOSE_UP_VIEWS: tuple[str, ...] = ("iso_se", "iso_nw", "iso_se_low", "front")
"""Views drawn for a close-up."""
CLOSE_UP_NOMINALS: float = 3.0
"""A mate close-up shows a cube of this many nominals (half-side) around the mate origin..."""
CLOSE_UP_PART_FRACTION: float = 0.25
"""...or this fraction of the larger partner's box diagonal, whichever is larger."""
GHOST_RGB: RGB = (176, 178, 186)
"""A close-up's other parts (parts mode) are drawn in this grey..."""
GHOST_ALPHA: float = 0.4
"""...and laid over the background at this opacity, never over the parts in focus."""


@dataclass
class Focus:
    """What a close-up shows: the parts drawn, the box fitted, the frames overlaid."""

    name: str
    parts: list[str]
    lo: np.ndarray
    hi: np.ndarray
    frames: list[tuple[str, np.ndarray]]
    axis_len: float


def resolve_focus(model: CompiledModel, name: str) -> Focus:
    """A close-up on part ``name`` (alone, with its frames), mate ``name`` (child + parent), or
    the pair ``"a+b"`` of two parts (a finding's pair: the two alone, fitted to where their
    boxes overlap, grown by half its size, or to both when they do not overlap)."""
    parts = {p.name: p for p in model.parts}
    if "+" in name and name not in parts:
        pair = name.split("+")
        missing = [n for n in pair if n not in parts]
        if len(pair) != 2 or missing:
            raise ValueError(f"close-up pair {name!r} must name two parts as 'a+b'; parts: "
                             f"{', '.join(parts)}")
        alo, ahi = scene.bounds(model, [pair[0]])
        blo, bhi = scene.bounds(model, [pair[1]])
        lo, hi = np.maximum(alo, blo), np.minimum(ahi, bhi)
        if np.any(lo > hi):
            lo, hi = np.minimum(alo, blo), np.maximum(ahi, bhi)
        grow = 0.5 * max(float(np.max(hi - lo)), 1.0)
        lo, hi = lo - grow, hi + grow
        return Focus(name, pair, lo, hi, [], float(np.linalg.norm(hi - lo)) * 0.12)
    if name in parts:
        lo, hi = scene.bounds(model, [name])
        p = parts[name]
        frames = [(f"{name}.{f}", p.world_frame(f)) for f in sorted(p.frames)]
        return Focus(name, [name], lo, hi, frames, float(np.linalg.norm(hi - lo)) * 0.12)
    for m in model.mates:
        if m.name == name:
            shown = [n for n in (m.parent, m.child) if n in parts]
            lo, hi = scene.bounds(model, shown)
            half = max(CLOSE_UP_NOMINALS * float(m.nominal or 0.0),
                       CLOSE_UP_PART_FRACTION * float(np.linalg.norm(hi - lo)), 1e-3)
            o = np.asarray(m.world_frame, float)[:3, 3]
            return Focus(name, shown, o - half, o + half, [(name, np.asarray(m.world_frame, float))],
                         half * 0.6)
    hint = did_you_mean(name, [*parts, *(m.name for m in model.mates)])
    raise ValueError(f"close-up target {name!r} is neither a part nor a mate{hint}; parts: "
                     f"{', '.join(parts)}; mates: {', '.join(m.name for m in model.mates) or '(none)'}")


def part_frames(model: CompiledModel, names: Sequence[str]) -> list[tuple[str, np.ndarray]]:
    """The frames of the parts ``names`` at their world poses, for the axes overlay: each part's
    own origin (its solved placement, labelled ``<part> origin``), then every frame it publishes
    (``<part>.<frame>``), in name order.

    Raises:
        ValueError: a name that is not a part (the message lists the parts).
    """
    parts = {p.name: p for p in model.parts}
    unknown = [n for n in names if n not in parts]
    if unknown:
        raise ValueError(f"no part named {', '.join(map(repr, unknown))}{did_you_mean(unknown[0], parts)} "
                         f"to draw the frames of; "
                         f"parts: {', '.join(parts) or '(none)'}")
    out: list[tuple[str, np.ndarray]] = []
    for name in dict.fromkeys(names):
        p = parts[name]
        out.append((f"{name} origin", np.asarray(p.placement, float)))
        out += [(f"{name}.{f}", np.asarray(p.world_frame(f), float)) for f in sorted(p.frames)]
    return out


def _check(mode: str, size: int) -> None:
    if mode not in MODES:
        raise ValueError(f"unknown render mode {mode!r}; use one of: {', '.join(MODES)}")
    if not SIZE_RANGE[0] <= int(size) <= SIZE_RANGE[1]:
        raise RangeError("render size", size, *SIZE_RANGE, unit="px")


def render_images(model: CompiledModel, views: str | list[str] | None = None, *, mode: Mode = "parts",
                  size: int = 512, focus: str | None = None,
                  frames_overlay: bool = False,
                  frames_of: Sequence[str] = (), ghost: bool = True) -> dict[str, Image.Image]:
    """Render ``views`` of ``model`` in memory: view name -> RGB PIL image (``size`` square).

    Args:
        model: the compiled assembly.
        views: catalog names (list or comma string; ``None`` = the 12 defaults, ``"all"`` = 20).
        mode: ``parts`` (distinct colour per part), ``clay`` (neutral, fixed rig), ``pbr``.
        size: image side in pixels, 32..4096.
        focus: a part or mate name for a close-up (draws only that part / the mate's two parts).
        ghost: in a close-up in ``parts`` mode, draw the other parts too, ghosted: grey
            (:data:`GHOST_RGB`), faded into the background (:data:`GHOST_ALPHA`) and never in
            front of the parts in focus, which stay whole (an x-ray of the pair in its place).
        frames_overlay: draw every mate frame's axes (a close-up always draws its own frames).
        frames_of: parts whose own origin and published frames are drawn as axes at their
            world poses (:func:`part_frames`): X red, Y green, Z blue.

    Raises:
        ValueError: an unknown mode, view, close-up or ``frames_of`` name.
    """
    _check(mode, size)
    names = parse_views(views)
    extra = part_frames(model, frames_of) if frames_of else []
    colors = part_colors([p.name for p in model.parts])
    shown = None
    if focus is not None:
        f = resolve_focus(model, focus)
        shown, lo, hi = f.parts, f.lo, f.hi
        frames, axis_len = f.frames, f.axis_len
    else:
        lo, hi = scene.bounds(model)
        frames = [(m.name, np.asarray(m.world_frame, float)) for m in model.mates] if frames_overlay else []
        axis_len = FRAME_AXIS_FRACTION * float(np.linalg.norm(hi - lo))
    if extra:
        drawn = {n for n, _ in frames}
        frames = list(frames) + [(n, m) for n, m in extra if n not in drawn]
    verts = scene.vertex_array(model, colors, shown)
    cams = [fit_camera(VIEWS[n], lo, hi) for n in names]
    ghosts: list[Any] = [None] * len(cams)
    if ghost and shown is not None and mode == "parts" and len(shown) < len(model.parts):
        grey = {n: (c if n in shown else GHOST_RGB) for n, c in colors.items()}
        ghosts = list(renderer().draw(scene.vertex_array(model, grey), cams, size, mode))
    out: dict[str, Image.Image] = {}
    for name, cam, pixels in zip(names, cams, _finished(verts, cams, size, mode, ghosts)):
        img = Image.fromarray(pixels, "RGB")
        if frames:
            compose.draw_frames(img, cam, frames, length=axis_len)
        out[name] = img
    return out


def _finished(verts: np.ndarray, cams: list[Any], size: int, mode: Mode,
              ghosts: list[Any]) -> list[np.ndarray]:
    """The output pixels of each camera: a line-free mode (``pbr``) finished on the GPU (the same
    bytes, a quarter of the pixels read back), the others composed here from the supersampled
    frames (outlines, ghosts)."""
    if compose.EDGE_STRENGTH[mode] == 0 and all(g is None for g in ghosts):
        return renderer().draw_finished(verts, cams, size, mode, compose.BACKGROUND[mode])
    out = []
    for frame, behind in zip(renderer().draw(verts, cams, size, mode), ghosts):
        pixels = compose.finish(frame, mode)
        if behind is not None:
            pixels = compose.ghosted(pixels, frame, compose.finish(behind, mode), mode, GHOST_ALPHA)
        out.append(pixels)
    return out


def sheet_image(model: CompiledModel, views: list[str], *, mode: Mode = "pbr",
                size: int = 384) -> Image.Image:
    """The contact sheet of ``views`` in memory (the ``sheet`` of :func:`render_to_dir`, pixel
    for pixel), without writing the views: what a build ships as ``sheet.png``."""
    images = render_images(model, views, mode=mode, size=size)
    return _sheet_of(model, [(v, images[v]) for v in views], mode, None)


def _sheet_of(model: CompiledModel, imgs: list[tuple[str, Image.Image]], mode: Mode,
              focus: str | None) -> Image.Image:
    """The contact sheet of ``imgs`` (view name, image) with its title and legend."""
    # the legend the sheet's own colours need: none for clay (one grey for all)
    legend = legend_of(model, mode) if mode != "clay" else []
    if focus is not None:
        shown = resolve_focus(model, focus).parts
        legend = [(n, c) for n, c in legend if n.split(" (")[0] in shown]
    title = f"{model.name}  mode={mode}" + (f"  close-up: {focus}" if focus else "")
    heading = "legend (material base colours)" if mode == "pbr" else "legend (part colours)"
    return compose.contact_sheet(imgs, title=title, legend=legend, heading=heading)


def legend_of(model: CompiledModel, mode: Mode = "parts") -> list[tuple[str, RGB]]:
    """(label, colour) for every part, in model order, as the ``mode``'s images show it: the
    part's palette colour (``parts``), or ``part (material)`` with the material's base colour
    (``pbr``)."""
    if mode == "pbr":
        out = []
        for p in model.parts:
            m = scene.material_of(model, p)
            out.append((f"{p.name} ({m.name})", tuple(round(255 * c) for c in m.rgb)))
        return out  # type: ignore[return-value]  # three channels from rgb
    colors = part_colors([p.name for p in model.parts])
    return [(p.name, colors[p.name]) for p in model.parts]


@dataclass
class RenderResult:
    """What :func:`render_to_dir` wrote and whether it shows the current program.

    Attributes:
        out_dir: the directory.
        paths: label -> file; labels are view names, ``closeup:<view>``, ``sheet``,
            ``closeup_sheet`` and ``legend``.
        legend: part name -> hex colour (the parts-mode colours).
        geometry: the geometry key of the model rendered.
        rendered: labels drawn by this call.
        cached: labels reused from an earlier call with the same key.
        stale_before: labels whose earlier file showed another program (now redrawn).
        current: every written image shows the current program (always true on return).
        seconds: wall time of the call.
    """

    out_dir: Path
    paths: dict[str, Path] = field(default_factory=dict)
    legend: dict[str, str] = field(default_factory=dict)
    geometry: str = ""
    rendered: list[str] = field(default_factory=list)
    cached: list[str] = field(default_factory=list)
    stale_before: list[str] = field(default_factory=list)
    current: bool = True
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return {"out_dir": str(self.out_dir), "paths": {k: str(v) for k, v in self.paths.items()},
                "legend": self.legend, "geometry": self.geometry, "rendered": self.rendered,
                "cached": self.cached, "stale_before": self.stale_before, "current": self.current,
                "seconds": round(self.seconds, 3)}


def render_to_dir(model: CompiledModel, out_dir: str | Path, *, views: str | list[str] | None = None,
                  mode: Mode = "parts", size: int = 512, sheet: bool = False,
                  close_up: str | None = None, frames_overlay: bool = False,
                  frames_of: Sequence[str] = ()) -> RenderResult:
    """Render views (and optionally a contact sheet and a close-up) of ``model`` into ``out_dir``.

    Files: ``<mode>_<view>.png``, ``<mode>_sheet.png``, ``<mode>_closeup_<name>_<view>.png``,
    ``<mode>_closeup_<name>_sheet.png``, ``legend.json`` and the cache manifest ``renders.json``.
    Images whose cache key matches the manifest are not redrawn. ``frames_of`` draws the named
    parts' origins and frames as axes in every image (:func:`part_frames`).

    Raises:
        ValueError: unknown mode, view, close-up or ``frames_of`` name (the message lists the
            valid ones).
        RangeError: ``size`` outside 32..4096 or more than 20 views.
    """
    t0 = time.perf_counter()
    _check(mode, size)
    names = parse_views(views)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    man = Manifest.load(out)
    geo = geometry_key(model)
    res = RenderResult(out_dir=out, geometry=geo,
                       legend={n: hex_color(c) for n, c in legend_of(model)})
    axes = [(n, np.round(m, 6).tolist()) for n, m in part_frames(model, frames_of)] if frames_of else []
    jobs: list[tuple[str | None, list[str], str]] = [(None, names, "")]
    if close_up is not None:
        resolve_focus(model, close_up)  # fail early on an unknown name
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in close_up)
        jobs.append((close_up, list(CLOSE_UP_VIEWS), f"closeup_{safe}_"))
    for focus, vnames, prefix in jobs:
        overlay = frames_overlay if focus is None else True
        keys = {v: image_key(model, geo, {"mode": mode, "size": size, "view": v, "focus": focus,
                                          "overlay": overlay, **({"axes": axes} if axes else {})})
                for v in vnames}
        files = {v: f"{mode}_{prefix}{v}.png" for v in vnames}
        todo = [v for v in vnames if not man.hit(files[v], keys[v])]
        images = render_images(model, todo, mode=mode, size=size, focus=focus,
                               frames_overlay=overlay, frames_of=frames_of) if todo else {}
        label = (lambda v: v) if focus is None else (lambda v: f"closeup:{v}")
        for v in vnames:
            path = out / files[v]
            res.paths[label(v)] = path
            if v in images:
                old = man.images.get(files[v])
                if old and old.get("geometry") != geo:
                    res.stale_before.append(label(v))
                images[v].save(path, optimize=False)
                man.images[files[v]] = {"key": keys[v], "geometry": geo, "view": v, "mode": mode,
                                        "size": size, "focus": focus}
                res.rendered.append(label(v))
            else:
                res.cached.append(label(v))
        if sheet:
            sheet_label = "sheet" if focus is None else "closeup_sheet"
            sheet_file = f"{mode}_{prefix}sheet.png"
            skey = image_key(model, geo, {"sheet": [keys[v] for v in vnames]})
            res.paths[sheet_label] = out / sheet_file
            if man.hit(sheet_file, skey):
                res.cached.append(sheet_label)
            else:
                imgs = [(v, images[v] if v in images else Image.open(out / files[v]).convert("RGB"))
                        for v in vnames]
                _sheet_of(model, imgs, mode, focus).save(out / sheet_file)
                man.images[sheet_file] = {"key": skey, "geometry": geo, "mode": mode, "size": size,
                                          "focus": focus}
                res.rendered.append(sheet_label)
    legend_path = out / "legend.json"
    legend_path.write_text(json.dumps(res.legend, indent=1))
    res.paths["legend"] = legend_path
    man.save()
    res.seconds = time.perf_counter() - t0
    log.info("rendered %d, reused %d images in %.2f s", len(res.rendered), len(res.cached), res.seconds)
    return res
