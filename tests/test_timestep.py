"""The critical time step against the true one: 2 / omega_max from the dense eigenvalues of
M^-1 K of the nodally integrated elastic system, on clouds a flow produces (jittered,
sheared, compressed, with crowded pairs and triples).  The bound must never exceed the true
step, must stay within a narrow factor of it, and must not collapse on crowded particles
(the element rule sqrt(A_e) / c_p did, by orders of magnitude)."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.materials.table import MaterialTable
from spfem_core.mesh import triangulate
from spfem_core.timestep import cell_frequency_bounds, critical_time_step, equalised_inertia
from verification.probes import smoothed_gradient

H = 1.0
N = 12
MATERIALS = MaterialTable.elastic("soil", 2000.0, 1e6, 0.3)
LAMBDA = float(MATERIALS.lame_lambda_pa[0])
SHEAR = float(MATERIALS.shear_modulus_pa[0])
D = np.array([[LAMBDA + 2 * SHEAR, LAMBDA, 0.0], [LAMBDA, LAMBDA + 2 * SHEAR, 0.0], [0.0, 0.0, SHEAR]])


def lattice() -> np.ndarray:
    x, y = np.meshgrid(np.arange(N) * H, np.arange(N) * H)
    return np.stack([x.ravel(), y.ravel()], axis=1)


LATTICE = lattice()
_, LATTICE_CELL_AREA = smoothed_gradient(LATTICE, np.zeros_like(LATTICE), triangulate(LATTICE, H).elem_nodes)
MASS_KG = 2000.0 * LATTICE_CELL_AREA  # fixed at the start, as in a run
MIDDLE = 5 * N + 5


def true_stable_step(xy: np.ndarray, elem_nodes: np.ndarray, mass_kg: np.ndarray = MASS_KG) -> float:
    """2 / sqrt(lambda_max(M^-1 K)), K = sum_k A_k B_k^T D B_k assembled column by column."""
    n = xy.shape[0]
    strain = np.zeros((n, 3, 2 * n))
    for dof in range(2 * n):
        unit = np.zeros((n, 2))
        unit[dof // 2, dof % 2] = 1.0
        grad, cell_area = smoothed_gradient(xy, unit, elem_nodes)
        strain[:, 0, dof], strain[:, 1, dof], strain[:, 2, dof] = grad[:, 0], grad[:, 3], grad[:, 1] + grad[:, 2]
    stiffness = np.einsum("k,kaj,ab,kbl->jl", cell_area, strain, D, strain)
    scale = 1.0 / np.sqrt(np.repeat(mass_kg, 2))
    return 2.0 / np.sqrt(np.linalg.eigvalsh(scale[:, None] * stiffness * scale[None, :]).max())


def bound(xy: np.ndarray, mesh, mass_kg: np.ndarray = MASS_KG) -> float:
    return critical_time_step(xy, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, mass_kg,
                              np.zeros(len(xy), dtype=np.int64), MATERIALS.lame_lambda_pa, MATERIALS.shear_modulus_pa)


def element_rule(xy: np.ndarray, elem_nodes: np.ndarray) -> float:
    a = xy[elem_nodes[:, 1]] - xy[elem_nodes[:, 0]]
    b = xy[elem_nodes[:, 2]] - xy[elem_nodes[:, 0]]
    area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    return float(np.sqrt(area.min()) / MATERIALS.p_wave_speed_m_s[0])


def clouds():
    rng = np.random.default_rng(7)
    yield "lattice", LATTICE.copy()
    for amplitude in (0.1, 0.3):
        yield f"jitter {amplitude} h", LATTICE + rng.uniform(-amplitude, amplitude, LATTICE.shape) * H
    for gap in (0.05, 1e-3):
        pair = LATTICE.copy()
        pair[MIDDLE] = LATTICE[MIDDLE + 1] - [gap * H, 0.0]
        yield f"pair {gap} h", pair
        floor_pair = LATTICE.copy()
        floor_pair[5] = LATTICE[6] - [gap * H, 0.0]  # on the bottom boundary
        yield f"boundary pair {gap} h", floor_pair
        triple = pair.copy()
        triple[MIDDLE + N] = LATTICE[MIDDLE + 1] + [-0.5 * gap * H, gap * H]
        yield f"triple {gap} h", triple
    for factor in (0.7, 0.3):
        squeezed = LATTICE.copy()
        squeezed[:, 0] *= factor
        yield f"compressed to {factor}", squeezed
    sheared = LATTICE.copy()
    sheared[:, 0] += 1.0 * sheared[:, 1]
    yield "sheared by 1", sheared


@pytest.mark.parametrize("name, xy", list(clouds()), ids=[name for name, _ in clouds()])
def test_bound_is_below_the_true_step_and_close_to_it(name, xy):
    mesh = triangulate(xy, H)
    ratio = true_stable_step(xy, mesh.elem_nodes) / bound(xy, mesh)
    assert 1.0 <= ratio <= 1.75, ratio  # measured 1.47-1.67


def test_bound_matches_the_element_rule_on_a_lattice():
    """Runs on lattices keep their step: sqrt(h^2 / 2) / c_p and the bound agree within 1%."""
    mesh = triangulate(LATTICE, H)
    assert bound(LATTICE, mesh) == pytest.approx(element_rule(LATTICE, mesh.elem_nodes), rel=0.01)


def test_crowded_particles_do_not_collapse_the_step():
    """A triple at 0.001 h: the element rule falls about 1000-fold, the bound by a few per cent."""
    triple = dict(clouds())["triple 0.001 h"]
    mesh = triangulate(triple, H)
    lattice_mesh = triangulate(LATTICE, H)
    assert element_rule(triple, mesh.elem_nodes) < 1e-2 * element_rule(LATTICE, lattice_mesh.elem_nodes)
    assert bound(triple, mesh) > 0.9 * bound(LATTICE, lattice_mesh)


def test_bound_scales_with_the_wave_speed():
    mesh = triangulate(LATTICE, H)
    stiff = critical_time_step(LATTICE, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, MASS_KG,
                               np.zeros(N * N, dtype=np.int64), 4.0 * MATERIALS.lame_lambda_pa,
                               4.0 * MATERIALS.shear_modulus_pa)
    assert stiff == pytest.approx(0.5 * bound(LATTICE, mesh), rel=1e-12)


@pytest.mark.parametrize("name, xy", list(clouds()), ids=[name for name, _ in clouds()])
def test_equalised_inertia_steps_every_cell_at_the_median_cell_and_stays_stable(name, xy):
    """Density scaling to a uniform step: after it no cell bounds omega^2 above the median cell's,
    so the bound's step is at least 2 / omega_median; the dense eigenvalues of the scaled system
    stay above it (the bound remains a bound); the particles whose cells and neighbours' cells lie
    below the median keep their mass."""
    mesh = triangulate(xy, H)
    rows = np.zeros(len(xy), dtype=np.int64)

    def cells(mass_kg):
        return cell_frequency_bounds(xy, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, mass_kg, rows,
                                     MATERIALS.lame_lambda_pa, MATERIALS.shear_modulus_pa)

    before = cells(MASS_KG)
    median = float(np.median(before[before > 0.0]))
    inertia = equalised_inertia(MASS_KG, before, mesh.node_node_ptr, mesh.node_node_idx)
    assert cells(inertia).max() <= median * (1.0 + 1e-12)
    step = bound(xy, mesh, inertia)
    assert step >= 2.0 / np.sqrt(median) * (1.0 - 1e-12) and step > 1.2 * bound(xy, mesh)
    assert step <= true_stable_step(xy, mesh.elem_nodes, inertia)
    stencil_high = before > median
    for k in np.flatnonzero(before > median):
        stencil_high[mesh.node_node_idx[mesh.node_node_ptr[k]:mesh.node_node_ptr[k + 1]]] = True
    assert np.array_equal(inertia[~stencil_high], MASS_KG[~stencil_high])
    assert np.all(inertia[stencil_high] > MASS_KG[stencil_high])


def test_a_relaxation_at_the_equalised_inertia_ends_in_the_same_state_in_fewer_steps():
    """An elastic block relaxed by damped steps with and without the equalised inertia: the same
    stresses within the tolerance's share of the largest, fewer steps, and the masses back (and the
    dynamic step) once the relaxation is over."""
    from spfem_core import Scene, SolverSettings
    from spfem_core.cloud import particles_in_polygon
    from spfem_core.simulation import Simulation

    xy = particles_in_polygon([[0, 0], [4, 0], [4, 2], [2, 4], [0, 4]], 0.2, jitter=0.1, seed=5)
    stiff = MaterialTable.elastic("soil", 2000.0, 1e8, 0.3)  # small strains: a hypoelastic end state path-free
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), stiff, 0.2, gravity_m_s2=[0.0, -10.0])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    runs = {}
    for uniform in (True, False):
        sim = Simulation(scene, SolverSettings(uniform_relaxation_step=uniform))
        dynamic_dt = sim.dt_s
        series = sim.relax(tolerance=1e-6, max_duration_s=20.0, elastic_solve_first=False)
        assert series.converged and series.dt_s > (1.2 if uniform else 0.99) * dynamic_dt / sim.settings.cfl
        np.testing.assert_array_equal(sim.nodes.inertia_kg, sim.nodes.mass_kg)
        assert sim.dt_s == pytest.approx(dynamic_dt, rel=0.01)  # the settled positions: a slightly other mesh
        runs[uniform] = (series.n_steps, sim.nodes.stress_pa.copy())
    scale = np.abs(runs[False][1]).max()
    assert np.abs(runs[True][1] - runs[False][1]).max() < 1e-4 * scale
    assert runs[True][0] < 0.8 * runs[False][0]
