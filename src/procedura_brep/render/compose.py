"""Image post-processing: outlines, background, down-sampling, mate-frame overlay, contact sheet.

All of it is numpy and PIL (the default bitmap font), so it is deterministic.
"""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from .gl import SUPERSAMPLE, Frame, Mode
from .palette import RGB
from .views import Camera, caption

BACKGROUND: dict[str, RGB] = {"parts": (246, 246, 246), "clay": (214, 214, 218), "pbr": (236, 237, 240)}
"""Flat background colour per mode (neutral grey, never a palette colour)."""
EDGE_STRENGTH: dict[str, float] = {"parts": 0.75, "clay": 0.45, "pbr": 0.0}
"""How much outlines darken a pixel, per mode (pbr renders are line-free)."""
CREASE_COS: float = math.cos(math.radians(40.0))
"""Neighbouring pixels whose normals differ by more than 40 degrees draw a crease line."""
AXIS_COLORS: tuple[RGB, RGB, RGB] = ((230, 30, 30), (20, 170, 40), (30, 70, 230))
"""Mate-frame overlay: X red, Y green, Z (the joint axis) blue."""


def finish(frame: Frame, mode: Mode) -> np.ndarray:
    """Composite background and outlines, box-filter by SUPERSAMPLE: (size, size, 3) uint8."""
    ids = frame.ids
    col = np.where((ids == 0)[..., None], np.array(BACKGROUND[mode], np.uint8), frame.color)
    strength = EDGE_STRENGTH[mode]
    if strength > 0:
        edge = np.zeros(ids.shape, bool)
        nrm = None if frame.normals is None else frame.normals.astype(np.int16) - 128
        limit = int(CREASE_COS * 127 * 127)
        for axis in (0, 1):
            a = [slice(None), slice(None)]
            b = [slice(None), slice(None)]
            a[axis], b[axis] = slice(None, -1), slice(1, None)
            ia, ib = ids[tuple(a)], ids[tuple(b)]
            d = ia != ib
            if nrm is not None:
                na, nb = nrm[tuple(a)], nrm[tuple(b)]
                dot = sum(na[..., k].astype(np.int32) * nb[..., k] for k in range(3))
                d |= (ia > 0) & (ib > 0) & (dot < limit)
            edge[tuple(a)] |= d
            edge[tuple(b)] |= d
        keep = int(round((1.0 - strength) * 256))
        col[edge] = (col[edge].astype(np.uint16) * keep >> 8).astype(np.uint8)
    s = SUPERSAMPLE
    total = sum(col[i::s, j::s].astype(np.uint16) for i in range(s) for j in range(s))
    return ((total + s * s // 2) // (s * s)).astype(np.uint8)


def ghosted(focus: np.ndarray, frame: Frame, whole: np.ndarray, mode: Mode, alpha: float) -> np.ndarray:
    """A close-up's image ``focus`` (its parts alone, from ``frame``) over ``whole`` (every
    part drawn, the others in a ghost grey) faded to ``alpha`` against the background: where
    the focus parts cover a pixel they stay as drawn, elsewhere the ghost shows through."""
    s = SUPERSAMPLE
    h, w = frame.ids.shape
    cover = (frame.ids > 0).reshape(h // s, s, w // s, s).mean(axis=(1, 3))[..., None]
    bg = np.array(BACKGROUND[mode], float)
    faded = bg + alpha * (whole.astype(float) - bg)
    out = focus.astype(float) + (1.0 - cover) * (faded - bg)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def coverage(frame: Frame) -> np.ndarray:
    """Part id per output pixel (top-left sample of each block; 0 = background), int32."""
    s = SUPERSAMPLE
    h, w = frame.ids.shape
    return frame.ids.reshape(h // s, s, w // s, s)[:, 0, :, 0].copy()


def draw_frames(image: Image.Image, camera: Camera, frames: list[tuple[str, np.ndarray]],
                *, length: float, labels: bool = True) -> None:
    """Draw each (name, world 4x4) frame's axes on ``image`` in place (no depth test).

    Each axis is a dark-outlined line of ``length`` mm from the frame origin: X red, Y green,
    Z blue (for a mate, Z is the joint axis, pointing from parent into child).
    """
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default()
    size = image.size[0]
    width = max(2, size // 256)
    for name, m in frames:
        o = m[:3, 3]
        pts = np.array([o] + [o + m[:3, k] * length for k in range(3)])
        px = camera.project(pts, size)
        if not np.all(np.isfinite(px)):
            continue
        for k in range(3):
            seg = [tuple(px[0]), tuple(px[k + 1])]
            draw.line(seg, fill=(20, 20, 20), width=width + 2)
            draw.line(seg, fill=AXIS_COLORS[k], width=width)
        r = width + 1
        x0, y0 = px[0]
        draw.ellipse([x0 - r, y0 - r, x0 + r, y0 + r], fill=(255, 255, 255), outline=(20, 20, 20))
        if labels:
            draw.text((x0 + r + 2, y0 + r), name, fill=(10, 10, 10), font=font,
                      stroke_width=1, stroke_fill=(255, 255, 255))


def legend_image(legend: list[tuple[str, RGB]], *, height: int, swatch: int = 14,
                 heading: str = "legend (part colours)") -> Image.Image:
    """A white column listing every part: a colour swatch and the name, wrapping into columns."""
    font = ImageFont.load_default()
    row = swatch + 6
    per_col = max(1, (height - 30) // row)
    ncols = max(1, math.ceil(len(legend) / per_col))
    col_w = swatch + 12 + max([int(font.getlength(n)) for n, _ in legend] + [60])
    img = Image.new("RGB", (ncols * col_w + 16, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    draw.text((8, 8), heading, fill=(0, 0, 0), font=font)
    for i, (name, rgb) in enumerate(legend):
        x = 8 + (i // per_col) * col_w
        y = 28 + (i % per_col) * row
        draw.rectangle([x, y, x + swatch, y + swatch], fill=rgb, outline=(0, 0, 0))
        draw.text((x + swatch + 6, y + 2), name, fill=(0, 0, 0), font=font)
    return img


def contact_sheet(images: list[tuple[str, Image.Image]], *, title: str,
                  legend: list[tuple[str, RGB]] | None,
                  heading: str = "legend (part colours)") -> Image.Image:
    """A grid of labelled views (ceil(sqrt(n)) columns) plus the legend on the right."""
    font = ImageFont.load_default()
    n = len(images)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    tile = images[0][1].size[0]
    label_h, pad, head = 16, 6, 24
    grid_w = cols * (tile + pad) + pad
    grid_h = head + rows * (tile + label_h + pad) + pad
    leg = legend_image(legend, height=grid_h, heading=heading) if legend else None
    sheet = Image.new("RGB", (grid_w + (leg.size[0] if leg else 0), grid_h), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    draw.text((pad, 6), title, fill=(0, 0, 0), font=font)
    for i, (name, img) in enumerate(images):
        x = pad + (i % cols) * (tile + pad)
        y = head + (i // cols) * (tile + label_h + pad)
        draw.text((x + 2, y + 2), caption(name), fill=(0, 0, 0), font=font)  # "front (from -Y, ortho)"
        sheet.paste(img, (x, y + label_h))
        draw.rectangle([x - 1, y + label_h - 1, x + tile, y + label_h + tile], outline=(180, 180, 180))
    if leg is not None:
        sheet.paste(leg, (grid_w, 0))
    return sheet
