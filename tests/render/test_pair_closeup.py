"""A close-up of the two parts of a pair finding (issue 23.4): the two alone, fitted to where
their boxes overlap."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledModel
from procedura_brep.render import resolve_focus
from procedura_brep.testing.models import cpart


def _box(x, y, z):
    from build123d import Align, Box
    return Box(x, y, z, align=(Align.MIN, Align.MIN, Align.MIN))


def test_a_pair_close_up_shows_the_two_parts_where_they_meet():
    model = CompiledModel("m", {}, [cpart("column", _box(40, 40, 300)),
                                    cpart("handle", _box(80, 10, 10), trans(30, 15, 150)),
                                    cpart("lamp", _box(20, 20, 20), trans(0, 0, 400))], [])
    f = resolve_focus(model, "handle+column")
    assert f.parts == ["handle", "column"]
    # the overlap box x 30..40, y 15..25, z 150..160 grown by half its size (5 mm a side)
    assert np.allclose(f.lo, [25, 10, 145], atol=0.2) and np.allclose(f.hi, [45, 30, 165], atol=0.2)
    with pytest.raises(ValueError, match="must name two parts"):
        resolve_focus(model, "handle+nothing")


def test_a_close_up_ghosts_the_other_parts_and_never_hides_the_pair():
    """Issue 23.4: the pair in colour, the rest ghosted. A plate stands in front of the pair (as
    seen from the front view) and a block beside it: both show only as faded grey, and the pair
    is drawn whole through the plate."""
    from procedura_brep.render import render_images
    from procedura_brep.render.compose import BACKGROUND
    model = CompiledModel("m", {}, [cpart("column", _box(40, 40, 300)),
                                    cpart("handle", _box(80, 10, 10), trans(30, 15, 150)),
                                    cpart("plate", _box(12, 2, 14), trans(38, 5, 148)),
                                    cpart("block", _box(4, 10, 8), trans(41, 15, 140))], [])
    alone = np.asarray(render_images(model, ["front"], size=96, focus="handle+column", ghost=False)["front"]).astype(int)
    ghost = np.asarray(render_images(model, ["front"], size=96, focus="handle+column")["front"]).astype(int)
    bg = np.array(BACKGROUND["parts"])
    pair = np.any(alone != bg, axis=2)
    same = np.all(alone == ghost, axis=2)
    assert pair.mean() > 0.1 and same[pair].mean() > 0.97  # the pair as drawn alone, through the plate
    shown = ~pair & ~same  # ghost pixels: greyish, lighter than the ghost grey, never a colour
    assert shown.mean() > 0.02
    px = ghost[shown]
    assert np.abs(px - px.mean(axis=1, keepdims=True)).max() <= 8 and px.min() >= 150
