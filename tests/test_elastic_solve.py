"""The direct elastic solve an elastic relaxation starts from (``spfem_core.elastic_solve``,
``Simulation.solve_elastic``): the state the damped steps converge to, and a clean refusal where it
does not apply."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core import MaterialTable, Scene
from spfem_core.cloud import particles_in_polygon
from spfem_core.elastic_solve import ElasticSystem, NotSolvable
from spfem_core.mesh import triangulate
from spfem_core.simulation import Simulation
from spfem_core.state import YY

H = 0.25


def column(base: bool) -> Scene:
    """A 2 m x 4 m elastic column under gravity, sides on rollers; the base fixed or free."""
    xy = particles_in_polygon([[0, 0], [2, 0], [2, 4], [0, 4]], H, jitter=0.1, seed=3)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", 2000.0, 1e7, 0.3), H,
                  gravity_m_s2=[0.0, -10.0])
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0)
    scene.fix(scene.select_box(x_min=2.0), vx_m_s=0.0)
    if base:
        scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene


def relaxed(scene: Scene, solve: bool):
    sim = Simulation(scene)
    series = sim.relax(tolerance=1e-6, max_duration_s=5.0, elastic_solve_first=solve)
    return sim, series


def test_the_solve_reaches_the_state_the_damped_steps_converge_to():
    solved, solved_series = relaxed(column(base=True), solve=True)
    stepped, stepped_series = relaxed(column(base=True), solve=False)
    assert solved_series.converged and stepped_series.converged
    assert solved_series.n_steps < 5 < stepped_series.n_steps
    assert solved_series.notes["elastic_solve"].startswith(("1 direct", "2 direct", "3 direct"))
    scale = np.abs(stepped.nodes.stress_pa).max()
    assert np.abs(solved.nodes.stress_pa - stepped.nodes.stress_pa).max() < 1e-4 * scale
    # and the column's own answer: sigma_yy = -rho g (H - y) away from the ends (K0 on rollers)
    depth = 4.0 - solved.initial_xy_m[:, 1]
    inside = (depth > 1.0) & (depth < 3.0)
    np.testing.assert_allclose(solved.nodes.stress_pa[inside, YY], -2000.0 * 10.0 * depth[inside], rtol=0.05)


def test_a_support_that_leaves_the_column_free_to_fall_is_refused_and_nothing_moves():
    sim = Simulation(column(base=False))
    xy = sim.nodes.xy_m.copy()
    note = sim.solve_elastic(tolerance=1e-5)
    assert note.startswith("not applicable")
    np.testing.assert_array_equal(sim.nodes.xy_m, xy)
    assert not np.any(sim.nodes.stress_pa)


def test_a_particle_outside_every_triangle_is_not_solvable():
    xy = particles_in_polygon([[0, 0], [1, 0], [1, 1], [0, 1]], H)
    mesh = triangulate(xy, H)
    far = np.vstack([xy, [[10.0, 10.0]]])
    n = far.shape[0]
    with pytest.raises(NotSolvable, match="no triangle"):
        ElasticSystem(far, mesh.elem_nodes, np.full(n, 1e6), np.full(n, 1e6), np.ones((n, 2), dtype=bool))
