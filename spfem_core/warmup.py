"""Compile every kernel of the time loop once, into the disk cache, before workers start.

Worker processes then load the compiled code from the cache instead of each compiling it
(about 5 s per process).  ``warm_up()`` runs a 12-particle plastic block on a fixed base, with
a wall out of reach, for a few steps, and the elastic copy of it relaxed from its direct solve:
the same argument types as any scene, so the same compiled signatures.
"""

from __future__ import annotations

import time

import numpy as np

from spfem_core.cloud import particles_in_polygon
from spfem_core.materials.table import MaterialTable
from spfem_core.scene import Scene
from spfem_core.simulation import Simulation


def warm_up() -> float:
    """Compile (or load from the cache) the kernels of a run with plasticity and a wall; wall seconds."""
    start = time.perf_counter()
    xy = particles_in_polygon([[0.0, 0.0], [3.0, 0.0], [3.0, 2.0], [0.0, 2.0]], 1.0)
    materials = MaterialTable.single("block", "drucker_prager", 2000.0, 1e7, 0.3, cohesion_pa=1e3, friction_deg=30.0)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), materials, 1.0, gravity_m_s2=[0.0, -10.0])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    scene.add_wall(-1.0, -10.0, 4.0, -10.0, friction=0.5)
    sim = Simulation(scene)
    sim.run(20 * sim.dt_s, damping=0.1, monitor_nodes=[0], stop=lambda t, u, k: None)
    sim.relax(tolerance=0.5, max_duration_s=5 * sim.dt_s)
    elastic = Scene(xy, np.zeros(len(xy), dtype=np.int64), materials.as_elastic(), 1.0, gravity_m_s2=[0.0, -10.0])
    elastic.fix(elastic.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    Simulation(elastic).relax(tolerance=0.5, max_duration_s=5 * sim.dt_s, elastic_solve_first=True)
    return time.perf_counter() - start
