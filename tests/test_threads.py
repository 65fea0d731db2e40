"""The threaded step gives the same bits on 1 and 2 threads (``spfem_core.jit`` module doc).

The check runs in a fresh process with NUMBA_NUM_THREADS=2, so that it exercises two threads
on any machine, one core or many: a sand column (Mohr-Coulomb, stabilisation, rough floor and a
wall, mesh rebuilds as it flows) and a loaded wet slope block (pore pressure, ponded water,
a surface load, tension cut-off) are each run on 1 and then on 2 threads, and every
per-particle array and every record must be identical (record times to 1e-12: their last bits follow how the
stage was cut into compiled calls, which follows the wall clock).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

CHECK = textwrap.dedent("""
    import numpy as np
    import numba
    from spfem_core.cloud import particles_in_polygon
    from spfem_core import MaterialTable, Scene, SolverSettings
    from spfem_core.simulation import Simulation

    assert numba.config.NUMBA_NUM_THREADS == 2

    def column(threads):
        xy = particles_in_polygon([[0.0, 0.0], [0.2, 0.0], [0.2, 0.4], [0.0, 0.4]], 0.004)
        sand = MaterialTable.single("sand", "mohr_coulomb", 2000.0, 5e6, 0.3, 0.0, 30.0, 0.0)
        scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), sand, 0.004, gravity_m_s2=[0.0, -9.81])
        scene.add_wall(-0.1, 0.0, 2.0, 0.0, friction=0.5)
        scene.add_wall(0.0, 1.0, 0.0, 0.0, friction=0.0)
        return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1, threads=threads)), 0.08

    def wet_block(threads):
        h = 0.08
        xy = particles_in_polygon([[0.0, 0.0], [10.0, 0.0], [10.0, 4.0], [0.0, 4.0]], h)
        clay = MaterialTable.single("clay", "mohr_coulomb", 1900.0, 2e7, 0.3, 5e3, 25.0, 0.0, tensile_strength_pa=1e3)
        top = (xy[:, 1] > 4.0 - 1e-9) & (xy[:, 0] >= 2.0) & (xy[:, 0] <= 4.0)
        load = np.zeros((len(xy), 2))
        load[top, 1] = -2e5 * 2.0 / top.sum()
        scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), clay, h, gravity_m_s2=[0.0, -9.81], node_load_n=load,
                      phreatic_lines_m=(np.array([[-1.0, 3.0], [11.0, 1.0]]),),
                      node_phreatic_line=np.zeros(len(xy), dtype=np.int64), pond_level_m=4.5)
        scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
        scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0)
        return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1, threads=threads)), 0.1

    for build in (column, wet_block):
        runs = []
        for threads in (1, 2):
            sim, duration_s = build(threads)
            series = sim.run(duration_s, record_interval_s=duration_s / 20)
            assert sim.threads == threads, (build.__name__, sim.threads)
            runs.append((sim, series))
        (one, series_one), (two, series_two) = runs
        assert series_one.n_steps == series_two.n_steps
        for name in ("xy_m", "displacement_m", "velocity_m_s", "stress_pa", "plastic_strain"):
            a, b = getattr(one.nodes, name), getattr(two.nodes, name)
            assert np.array_equal(a, b), (build.__name__, name, np.abs(a - b).max())
        for name in ("energy_j_per_m", "max_displacement_m", "max_speed_m_s"):
            a, b = getattr(series_one, name), getattr(series_two, name)
            assert np.array_equal(a, b), (build.__name__, name)
        # stage time is summed per compiled call, whose length follows the wall clock: the last bits
        # of the record times depend on it (not on the threads), the state does not
        np.testing.assert_allclose(series_one.time_s, series_two.time_s, rtol=1e-12, atol=0.0)
        assert one.counters.rebuilds == two.counters.rebuilds
        print(build.__name__, one.n_particles, "particles,", series_one.n_steps, "steps,",
              one.counters.rebuilds, "rebuilds, plastic", int((one.nodes.plastic_strain > 0).sum()))
""")


def test_one_and_two_threads_give_identical_runs():
    env = dict(os.environ, NUMBA_NUM_THREADS="2")
    done = subprocess.run([sys.executable, "-c", CHECK], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.strip().splitlines()
    assert [line.split()[0] for line in lines] == ["column", "wet_block"]
    for line in lines:  # the scenes did what they are there for: flow, rebuild, yield
        words = line.split()
        assert int(words[words.index("rebuilds,") - 1]) >= (1 if words[0] == "column" else 0)
        assert int(words[-1]) > 0


ONE_THREAD = textwrap.dedent("""
    from spfem_core import constitutive, integration, nodal_force, smoothing
    from spfem_core.warmup import warm_up

    warm_up()  # plasticity, a wall, run and relax: every kernel of a step, on one thread
    helpers = (smoothing.smooth_blocks_threaded, constitutive.update_stress_threaded,
               nodal_force.element_forces_threaded, nodal_force.bond_forces_threaded,
               integration.leapfrog_threaded)
    print(sum(len(helper.signatures) for helper in helpers), len(smoothing.smooth_elements.signatures))
""")


def test_a_one_thread_run_compiles_no_threaded_code(tmp_path):
    """On one thread the kernels get n_threads = None and numba drops the threaded branch before
    compiling (``jit.kernel_threads``): with an empty cache, compiling every kernel of a step
    compiles no parallel helper, while the plain block functions they share are compiled."""
    env = dict(os.environ, SPFEM_CACHE_DIR=str(tmp_path / "numba-cache"))
    done = subprocess.run([sys.executable, "-c", ONE_THREAD], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    n_threaded, n_block_function = map(int, done.stdout.split())
    assert n_block_function == 1  # compiled here, not loaded: the count sees what was compiled
    assert n_threaded == 0
