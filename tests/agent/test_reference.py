"""The reference a model is shown is generated from the code and says what the compiler does."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.agent.prompts import FRAME_ROTATIONS, reference
from procedura_brep.mates import TYPES


def test_every_option_of_every_mate_type_has_its_range_and_meaning():
    ref = reference()
    for t in TYPES.values():
        block = ref.split(f"- {t.name} (", 1)[1].split("\n- ", 1)[0]
        for name, opt in t.options.items():
            line = next((x for x in block.splitlines() if x.strip().startswith(f"- {name} = ")), None)
            assert line is not None, (t.name, name)
            assert opt.doc and opt.doc in line, (t.name, name)
            if opt.choices:
                assert all(repr(c) in line for c in opt.choices), (t.name, name)
            elif opt.low is not None or opt.high is not None:
                assert opt.range_text() in line, (t.name, name)
        assert all(f in block for f in t.fits)


def test_stated_frame_rotations_are_build123d_s():
    b3d = pytest.importorskip("build123d")
    axes = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0), "+Z": (0, 0, 1), "-Z": (0, 0, -1)}
    for rot, z, x in FRAME_ROTATIONS:
        loc = b3d.Location((0, 0, 0), rot)
        got_z = (loc * b3d.Location((0, 0, 1))).position
        got_x = (loc * b3d.Location((1, 0, 0))).position
        assert np.allclose(tuple(got_z), axes[z], atol=1e-9), rot
        assert np.allclose(tuple(got_x), axes[x], atol=1e-9), rot


def test_reference_states_the_gate_limits_and_densities():
    from procedura_brep.config import TOL
    from procedura_brep.materials import MATERIALS
    ref = reference()
    assert f">= {TOL.registration_tau:g} d^2" in ref and f"at least {TOL.span_tau:g}" in ref
    assert f"closer than {TOL.connect_mm:g} mm" in ref
    assert all(f"{m.name} ({m.material_class}, {m.density:g})" in ref for m in MATERIALS.values())
    assert "M64" in ref and "up to 500 mm" in ref and "`home`" in ref
    # touching is contact, and the two interference limits a model works against
    assert "coincident faces are contact" in ref
    assert f"thicker than {TOL.penetration_slack_mm:g} mm fails" in ref
    assert f"at most {TOL.sim_penetration_mm:g} mm" in ref


def test_the_mate_docstring_names_every_mate_type():
    """The request shows mate()'s docstring: it named every type but `cylindrical` (issue 23.6)."""
    import inspect

    from procedura_brep.mates import TYPES
    from procedura_brep.program import api

    doc = inspect.getdoc(api.mate) or ""
    missing = [name for name in TYPES if f"``{name}``" not in doc]
    assert not missing, missing
