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
