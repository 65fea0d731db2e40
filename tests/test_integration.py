"""The leapfrog a scene without slip supports and without scaled inertia runs
(``spfem_core.integration``, module doc): it reads neither, and steps to the same bits as the
leapfrog that reads them."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core import stage_loop
from spfem_core.integration import leapfrog
from spfem_core.materials.table import MaterialTable
from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.stage_setup import Supports
from spfem_core.state import LEAPFROG_OUT_WIDTH

DT_S = 1e-3


def stepped(reads_rows: bool, n_steps: int = 5):
    """(positions, displacements, velocities, contacts, the out slots of every step) of particles
    pushed about near a floor wall, a quarter of their directions fixed, with damping; through the
    leapfrog given the inertia (= the masses) and slip rows of no support, or given no rows of either."""
    rng = np.random.default_rng(7)
    n = 64
    xy = rng.uniform(0.0, 1.0, (n, 2))
    xy[:, 1] *= 0.05  # close to the floor, so that the wall acts on some
    velocity = rng.normal(0.0, 0.3, (n, 2))
    mass = rng.uniform(0.5, 2.0, n)
    fixed = rng.uniform(size=(n, 2)) < 0.25
    fixed_velocity = np.where(fixed, rng.normal(0.0, 0.1, (n, 2)), 0.0)
    wall_xy, wall_friction = np.array([[-1.0, 0.0, 2.0, 0.0]]), np.array([0.3])
    u, contact, out = np.zeros((n, 2)), np.zeros(n, dtype=np.int64), np.zeros(LEAPFROG_OUT_WIDTH)
    outs = []
    for _ in range(n_steps):
        force = rng.normal(0.0, 5.0, (n, 2))
        inertia, slip = (mass.copy(), np.zeros((n, 3))) if reads_rows else (np.zeros(0), np.zeros((0, 3)))
        leapfrog(xy, u, velocity, force, mass, inertia, fixed, fixed_velocity, slip, np.array([0.0, -9.81]), 0.7,
                 DT_S, wall_xy, wall_friction, 0.05, contact, out, None)
        outs.append(out.copy())
    return xy, u, velocity, contact, np.array(outs)


def test_the_leapfrog_without_inertia_and_slip_rows_steps_to_the_same_bits():
    with_rows, without = stepped(reads_rows=True), stepped(reads_rows=False)
    assert with_rows[3].any()  # the wall acted
    for a, b in zip(with_rows, without):
        np.testing.assert_array_equal(a, b)


@pytest.fixture
def column(make_column):
    return Simulation(make_column(0.5), SolverSettings(cfl=0.5))


def test_a_stage_steps_without_the_rows_only_while_it_has_no_slip_support_and_no_scaled_inertia(column):
    sim = column
    assert stage_loop._plain_leapfrog(sim)
    sim.nodes.inertia_kg[0] *= 2.0  # a density-scaled relaxation's inertia
    assert not stage_loop._plain_leapfrog(sim)
    sim.nodes.inertia_kg[:] = sim.nodes.mass_kg
    sim.set_materials(MaterialTable.single("sand", "mohr_coulomb", 2000.0, 1e8, 0.3, 5e3, 30.0, 0.0))
    base = np.flatnonzero(sim.initial_xy_m[:, 1] == sim.initial_xy_m[:, 1].min())
    fixed = np.zeros((sim.n_particles, 2), dtype=bool)
    fixed[base, 1] = True
    side, length = np.zeros(sim.n_particles), np.zeros(sim.n_particles)
    side[base], length[base] = -1.0, 0.5
    sim.set_supports(Supports.of(sim.n_particles, fixed, np.zeros((sim.n_particles, 2)), length, side))
    assert not stage_loop._plain_leapfrog(sim)  # the column's base slides on the soil's strength
    sim.set_supports(Supports.of(sim.n_particles, fixed, np.zeros((sim.n_particles, 2))))
    assert stage_loop._plain_leapfrog(sim)


def test_the_leapfrog_refuses_inertia_without_slip_rows():
    n = 2
    with pytest.raises(ValueError, match="together"):
        leapfrog(np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2)), np.ones(n), np.ones(n),
                 np.zeros((n, 2), dtype=bool), np.zeros((n, 2)), np.zeros((0, 3)), np.zeros(2), 0.0, DT_S,
                 np.zeros((0, 4)), np.zeros(0), 0.05, np.zeros(n, dtype=np.int64), np.zeros(LEAPFROG_OUT_WIDTH), None)
