"""Crowded particles are spread by one Laplacian pass when the mesh is rebuilt: interior ones
towards the mean of their neighbours, boundary ones along the boundary, fixed ones never."""

from __future__ import annotations

import numpy as np

from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.cloud import particles_in_polygon
from spfem_core.simulation import Simulation

H = 0.1


def block_with_crowded_pairs(crowd_the_base: bool = True):
    """A 1 x 0.5 m lattice block on a fixed base with three crowded particles (0.05 h from a
    neighbour): one on the free top surface, one interior, one on the fixed base row."""
    xy = particles_in_polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]], H)
    top = int(np.flatnonzero(np.isclose(xy[:, 0], 0.5) & np.isclose(xy[:, 1], 0.5))[0])
    inner = int(np.flatnonzero(np.isclose(xy[:, 0], 0.5) & np.isclose(xy[:, 1], 0.2))[0])
    base = int(np.flatnonzero(np.isclose(xy[:, 0], 0.5) & np.isclose(xy[:, 1], 0.0))[0])
    xy[top, 0] = 0.405  # towards (0.4, 0.5), along the surface
    xy[inner, 0] = 0.405  # towards (0.4, 0.2)
    if crowd_the_base:
        xy[base, 0] = 0.405  # towards (0.4, 0.0), but fixed
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", 2000.0, 5e6, 0.3), H,
                  gravity_m_s2=[0.0, -9.81])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene, top, inner, base


def nearest_distance(xy, k):
    d = np.hypot(*(xy - xy[k]).T)
    d[k] = np.inf
    return d.min()


def test_rebuild_spreads_crowded_particles_and_keeps_the_boundary():
    scene, top, inner, base = block_with_crowded_pairs()
    sim = Simulation(scene, SolverSettings(cfl=0.5))
    start = sim.nodes.xy_m.copy()
    sim.rebuild_mesh()  # what a remesh does: rebuild, smooth the crowded particles, rebuild again

    xy = sim.nodes.xy_m
    assert sim.counters.smoothed >= 2
    # the surface particle slid along the surface: still on it, now about h/2 from each neighbour
    assert xy[top, 1] == 0.5
    assert nearest_distance(xy, top) > 0.4 * H
    # the interior one went to the mean of its neighbours
    assert nearest_distance(xy, inner) > 0.4 * H
    # a fixed particle stays where it is, crowded or not
    assert np.array_equal(xy[base], start[base])
    # displacement follows position everywhere
    np.testing.assert_allclose(sim.nodes.displacement_m, xy - start, atol=1e-15)


def test_crowded_particles_do_not_set_the_time_step():
    """Pairs at 0.05 h leave the step within 10% of the uniform block's (the element rule
    sqrt(A_e) / c_p cut it more than threefold; ``tests/test_timestep.py``)."""
    crowded = Simulation(block_with_crowded_pairs()[0], SolverSettings(cfl=0.5))
    xy = particles_in_polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]], H)
    uniform = Simulation(Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", 2000.0, 5e6, 0.3),
                               H), SolverSettings(cfl=0.5))
    assert crowded.critical_dt_s > 0.9 * uniform.critical_dt_s


def test_nothing_moves_on_an_uncrowded_lattice():
    xy = particles_in_polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]], H)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", 2000.0, 5e6, 0.3), H)
    sim = Simulation(scene, SolverSettings(cfl=0.5))
    sim.rebuild_mesh()
    assert sim.counters.smoothed == 0 and np.array_equal(sim.nodes.xy_m, xy)
