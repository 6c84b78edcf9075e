"""The surface-cell cover of :mod:`procedura_brep.sim.cells`: bounded for a huge part, and
conservative (every surface point inside a sphere) whatever the cell side it ends up with."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.config import TOL
from procedura_brep.sim.cells import MAX_SUBDIV, _triangles, cell_side, cover


def _tri(a: float) -> np.ndarray:
    """One right triangle with legs ``a`` (mm)."""
    return np.array([[[0.0, 0, 0], [a, 0, 0], [0, a, 0]]])


def test_a_small_surface_keeps_the_fine_cell():
    assert cell_side(_tri(10.0)) == TOL.sweep_cell_mm


def test_a_huge_surface_gets_cells_sized_to_the_cap():
    area = 0.5 * 1e5 ** 2
    side = cell_side(_tri(1e5), max_cells=1000)
    assert side >= np.sqrt(area / 1000) - 1e-9
    # and never so coarse that one edge needs more than MAX_SUBDIV points at half a cell
    assert np.sqrt(2) * 1e5 / (side / 2) <= MAX_SUBDIV + 1e-9


def test_a_long_edge_widens_the_cell_so_the_spacing_holds():
    thin = np.array([[[0.0, 0, 0], [1e6, 0, 0], [0, 1.0, 0]]])  # Cylinder(1e6, 1)'s kind
    side = cell_side(thin, max_cells=10**9)
    assert 1e6 / (side / 2) <= MAX_SUBDIV + 1e-9


@pytest.fixture(scope="module")
def sphere_shape(worker):
    from procedura_brep.program import compile_source
    from tests.sim.fin import program as fin_program
    model = compile_source(fin_program(None), name="fin", worker=worker)
    return model.part("post").shape()


@pytest.mark.parametrize("max_cells", [50, 400, None])
def test_the_cover_holds_every_surface_point_at_any_cell_side(sphere_shape, max_cells):
    """Vertices, edge midpoints and centroids of the part's triangles all lie inside a cover
    sphere, for a cover forced coarse (50 cells) as for the default one."""
    from procedura_brep.kernel import _ocp
    c = cover(sphere_shape, max_cells=max_cells)
    if max_cells is not None:
        assert len(c.centres) <= 4 * max_cells  # about max_cells (cells, not area, are counted)
        assert c.radius > TOL.sweep_cell_mm  # widened
    o = _ocp()
    exp = o["TopExp"].TopExp_Explorer(sphere_shape, o["TopAbs"].TopAbs_FACE)
    tris = []
    while exp.More():
        tris.append(_triangles(o["TopoDS"].TopoDS.Face(exp.Current()), o))
        exp.Next()
    t = np.vstack(tris)
    pts = np.vstack([t.reshape(-1, 3), (t + np.roll(t, 1, axis=1)).reshape(-1, 3) / 2, t.mean(axis=1)])
    d = np.min(np.linalg.norm(pts[:, None, :] - c.centres[None, :, :], axis=2), axis=1) \
        if len(c.centres) < 2000 else _nearest(pts, c.centres)
    assert d.max() <= c.radius, (d.max(), c.radius)


def _nearest(pts: np.ndarray, centres: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree
    return cKDTree(centres).query(pts)[0]
