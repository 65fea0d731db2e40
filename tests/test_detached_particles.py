"""A particle outside the mesh flies under gravity, is counted, and rejoins when it lands."""

from __future__ import annotations

import numpy as np

from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.cloud import particles_in_polygon
from spfem_core.simulation import Simulation


def test_detached_particle_falls_lands_and_rejoins_the_mesh():
    h = 0.1
    block = particles_in_polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]], h)
    xy = np.vstack([block, [[0.55, 1.2]]])  # 0.7 m above the top: far beyond alpha h
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", 2000.0, 5e6, 0.3), h,
                  gravity_m_s2=[0.0, -9.81])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    sim = Simulation(scene, SolverSettings(cfl=0.5), allow_detached=True)
    flyer = len(xy) - 1
    assert sim.n_orphans == 1 and flyer in sim.mesh.orphan_nodes
    mass = sim.nodes.mass_kg.sum()

    flight = sim.run(0.2, damping=0.0)
    assert "1 at the end" in flight.notes["particles_outside_mesh"]
    drop = 1.2 - sim.nodes.xy_m[flyer, 1]
    assert abs(drop - 0.5 * 9.81 * 0.2**2) < 0.01 * drop  # free fall while detached

    sim.run(1.0, damping=0.3)
    assert sim.n_orphans == 0 and flyer not in sim.mesh.orphan_nodes  # it has joined the mesh
    assert sim.nodes.xy_m[flyer, 1] > 0.4  # it rests on the block, not inside or through it
    assert np.all(np.isfinite(sim.nodes.xy_m))
    assert sim.nodes.mass_kg.sum() == mass
