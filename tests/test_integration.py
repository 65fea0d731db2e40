"""The leapfrog a scene without scaled inertia runs (``spfem_core.integration``, module doc): it
reads no inertia, and slip rows only for the particles on a slip support, and steps to the same bits
as the leapfrog that reads them all."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core import stage_loop
from spfem_core.integration import leapfrog
from spfem_core.materials.table import MaterialTable
from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.stage_setup import Supports
from spfem_core.state import LEAPFROG_CONTACT_LOSS, LEAPFROG_OUT_WIDTH, SLIP_COHESION, SLIP_FRICTION, SLIP_SIDE

DT_S = 1e-3


def stepped(reads_rows: bool, n_steps: int = 5, slip_nodes=()):
    """(positions, displacements, velocities, contacts, the out slots of every step) of particles
    pushed about near a floor wall, a quarter of their directions fixed, with damping; through the
    leapfrog given the inertia (= the masses), or given no inertia rows.  The particles ``slip_nodes``
    are on a slip support along x (y held, the floor below them), some stuck and some sliding; the
    others on none."""
    rng = np.random.default_rng(7)
    n = 64
    xy = rng.uniform(0.0, 1.0, (n, 2))
    xy[:, 1] *= 0.05  # close to the floor, so that the wall acts on some
    velocity = rng.normal(0.0, 0.3, (n, 2))
    mass = rng.uniform(0.5, 2.0, n)
    fixed = rng.uniform(size=(n, 2)) < 0.25
    fixed_velocity = np.where(fixed, rng.normal(0.0, 0.1, (n, 2)), 0.0)
    slip_nodes = np.array(slip_nodes, dtype=np.int64)
    slip = np.zeros((n, 3))
    fixed[slip_nodes] = (False, True)
    fixed_velocity[slip_nodes] = 0.0
    slip[slip_nodes, SLIP_SIDE] = -1.0
    slip[slip_nodes, SLIP_COHESION] = rng.uniform(0.0, 8.0, slip_nodes.size)  # some hold, some slide
    slip[slip_nodes, SLIP_FRICTION] = 0.5
    wall_xy, wall_friction = np.array([[-1.0, 0.0, 2.0, 0.0]]), np.array([0.3])
    u, contact, out = np.zeros((n, 2)), np.zeros(n, dtype=np.int64), np.zeros(LEAPFROG_OUT_WIDTH)
    outs = []
    for _ in range(n_steps):
        force = rng.normal(0.0, 5.0, (n, 2))
        inertia = mass.copy() if reads_rows else np.zeros(0)
        leapfrog(xy, u, velocity, force, mass, inertia, fixed, fixed_velocity, slip, slip_nodes,
                 np.array([0.0, -9.81]), 0.7, DT_S, wall_xy, wall_friction, 0.05, contact, out, None)
        outs.append(out.copy())
    return xy, u, velocity, contact, np.array(outs)


def test_the_leapfrog_without_inertia_rows_steps_to_the_same_bits():
    with_rows, without = stepped(reads_rows=True), stepped(reads_rows=False)
    assert with_rows[3].any()  # the wall acted
    for a, b in zip(with_rows, without):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("slip_nodes", [
    pytest.param((0, 1, 2, 17, 18, 40, 63), id="runs-at-both-ends-and-between"),
    pytest.param(tuple(range(64)), id="every-particle"),
])
def test_the_leapfrog_reading_slip_rows_only_on_the_supports_steps_to_the_same_bits(slip_nodes):
    """Before: a scene with a slip support (a slope on its default rough base) read every particle's
    inertia and slip row; now the plain range runs between the supported particles, the general one
    over them, the sums carried in the particles' order: the same bits."""
    with_rows, without = stepped(True, slip_nodes=slip_nodes), stepped(False, slip_nodes=slip_nodes)
    assert with_rows[4][:, LEAPFROG_CONTACT_LOSS].any()  # the supports held some and resisted others
    for a, b in zip(with_rows, without):
        np.testing.assert_array_equal(a, b)


@pytest.fixture
def column(make_column):
    return Simulation(make_column(0.5), SolverSettings(cfl=0.5))


def test_a_stage_steps_without_the_inertia_rows_only_while_its_inertia_is_the_mass(column):
    sim = column
    assert stage_loop._inertia_is_mass(sim)
    sim.nodes.inertia_kg[0] *= 2.0  # a density-scaled relaxation's inertia
    assert not stage_loop._inertia_is_mass(sim)
    sim.nodes.inertia_kg[:] = sim.nodes.mass_kg
    sim.set_materials(MaterialTable.single("sand", "mohr_coulomb", 2000.0, 1e8, 0.3, 5e3, 30.0, 0.0))
    base = np.flatnonzero(sim.initial_xy_m[:, 1] == sim.initial_xy_m[:, 1].min())
    fixed = np.zeros((sim.n_particles, 2), dtype=bool)
    fixed[base, 1] = True
    side, length = np.zeros(sim.n_particles), np.zeros(sim.n_particles)
    side[base], length[base] = -1.0, 0.5
    sim.set_supports(Supports.of(sim.n_particles, fixed, np.zeros((sim.n_particles, 2)), length, side))
    assert stage_loop._inertia_is_mass(sim)  # the column's base slides on the soil's strength: its rows alone read


def test_the_leapfrog_refuses_inertia_without_slip_rows():
    n = 2
    with pytest.raises(ValueError, match="with the slip rows"):
        leapfrog(np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2)), np.ones(n), np.ones(n),
                 np.zeros((n, 2), dtype=bool), np.zeros((n, 2)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64),
                 np.zeros(2), 0.0, DT_S,
                 np.zeros((0, 4)), np.zeros(0), 0.05, np.zeros(n, dtype=np.int64), np.zeros(LEAPFROG_OUT_WIDTH), None)
