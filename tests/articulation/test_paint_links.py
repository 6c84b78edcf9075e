"""A colour block rides in its painted part's link: it moves with it, is not a floater and
needs no mate; its mass is its own material's (issue 13, item 6)."""

from __future__ import annotations

import pytest

from procedura_brep import kernel
from procedura_brep.articulation import articulate, link_masses
from procedura_brep.materials import MATERIALS

from ..program.painted import painted_lamp


@pytest.fixture(scope="module")
def lamp(worker):
    from procedura_brep.program import compile_source
    return compile_source(painted_lamp(), name="lamp", worker=worker)


def test_the_block_is_in_its_part_link(lamp):
    art = articulate(lamp)
    assert {lk.name: lk.parts for lk in art.links} == {"base": ["base", "post"], "arm": ["arm", "arm_tip"]}
    assert [j.name for j in art.joints] == ["arm_pivot"]


def test_the_link_mass_counts_the_block_in_its_own_density(lamp):
    from procedura_brep.articulation.mass import part_mass
    tip = lamp.part("arm_tip")
    assert part_mass(lamp, "arm_tip").mass == pytest.approx(
        kernel.volume(tip.local_shape()) * MATERIALS["rubber"].density * 1e-9, rel=1e-9)
    masses = link_masses(lamp, articulate(lamp))
    assert masses["arm"].mass == pytest.approx(part_mass(lamp, "arm").mass + part_mass(lamp, "arm_tip").mass,
                                               rel=1e-9)
