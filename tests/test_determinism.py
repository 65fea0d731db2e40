"""A run does not depend on how the time loop is cut into compiled calls (their length follows
the wall clock): the same scene gives the same state, bit for bit, on a fast or a slow machine."""

from __future__ import annotations

import numpy as np
import pytest

import spfem_core.schedule as schedule
from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.cloud import particles_in_polygon
from spfem_core.simulation import Simulation


def falling_particle_on_a_plastic_block():
    """A plastic block on a fixed base and one particle dropped onto it: detached particles,
    landing checks, remeshing."""
    h = 0.1
    block = particles_in_polygon([[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]], h)
    xy = np.vstack([block, [[0.55, 1.2]]])
    materials = MaterialTable.single("soil", "drucker_prager", 2000.0, 5e6, 0.3, cohesion_pa=500.0,
                                     friction_deg=20.0)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), materials, h, gravity_m_s2=[0.0, -9.81])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1), allow_detached=True)


def run(wall_seconds_per_call, monkeypatch):
    monkeypatch.setattr(schedule, "WALL_SECONDS_PER_CALL", wall_seconds_per_call)
    sim = falling_particle_on_a_plastic_block()
    asked = []

    def stop(time_s, max_u_m, energy):
        asked.append(float(time_s[-1]))
        return "moved 0.55 m" if max_u_m.max() > 0.55 else None

    series = sim.run(1.0, damping=0.0, record_interval_s=0.01, monitor_nodes=[0], stop=stop)
    return sim, series, asked


def test_a_run_is_the_same_whatever_the_length_of_the_compiled_calls(monkeypatch):
    long_sim, long_series, long_asked = run(0.25, monkeypatch)
    short_sim, short_series, short_asked = run(1e-6, monkeypatch)  # calls of 10 steps
    assert "moved" in long_series.notes["early_stop"]  # the stop rule fired, after the particle landed
    assert long_sim.counters.rebuilds >= 1 and long_sim.n_orphans == 0
    assert short_sim.counters.steps == long_sim.counters.steps
    assert np.array_equal(short_sim.nodes.xy_m, long_sim.nodes.xy_m)
    assert np.array_equal(short_sim.nodes.stress_pa, long_sim.nodes.stress_pa)
    assert short_asked == pytest.approx(long_asked, abs=1e-12)  # asked at the same times
