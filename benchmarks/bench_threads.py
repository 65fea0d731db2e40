"""Thread speed-up of the compiled step: one big run on 1 and 2 threads, and against another checkout.

    python -m benchmarks.bench_threads                            # 5k, 20k, 80k particles, 3 repeats
    python -m benchmarks.bench_threads --compare ../serial-tree   # and a checkout before the threads
    python -m benchmarks.bench_threads --sizes 1k 100k            # the one-thread cost, 100k over 1k

Two scenes, built from core calls every version has: the elastic cantilever beam with
stabilisation (beta = 0.1, as ``bench_core``) and a sand column (Mohr-Coulomb, c = 0,
phi = 30 deg, no gravity stage) released on a rough floor: every particle yields, the mesh is
rebuilt as it flows, the wall contact runs; the scene of a collapse or runout.  Each
measurement is a fresh process with a warm numba cache and ``NUMBA_NUM_THREADS`` set: one
warm-up call, then a fixed number of steps (the column: the same steps from the release, so
every configuration runs the same flow) timed; the median of ``repeats`` alternated runs is
quoted, in million particle-steps per second, and the ratios in the same command.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from benchmarks.bench_core import SAND_COLUMN

ROOT = Path(__file__).resolve().parents[1]
SIZES = {"1k": 1_000, "5k": 5_000, "20k": 20_000, "80k": 80_000, "100k": 100_000}
DEFAULT_SIZES = ("5k", "20k", "80k")

SCENES = SAND_COLUMN + """
import json, math, time

def beam(n):
    h = math.sqrt(2.0 * 0.2 / n)
    xy = particles_in_polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]], h)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("beam", 1850.0, 80e6, 0.25), h,
                  gravity_m_s2=[0.0, -9.8])
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1)), 20

def column(n):
    return sand_column(math.sqrt(0.2 * 0.4 / n), 0.1), 0

sim, warm_steps = {scene}({n})
steps = max(100, int({particle_steps} / sim.n_particles))
if warm_steps:
    sim.run(warm_steps * sim.dt_s)  # compiled code loaded, caches hot
else:
    probe, _ = {scene}(2000)  # the column must start from rest: warm the code on a small copy
    probe.run(20 * probe.dt_s)
start = time.perf_counter()
series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
wall = time.perf_counter() - start
print(json.dumps({{"n": sim.n_particles, "rate": sim.n_particles * series.n_steps / wall,
                   "rebuilds": int(series.n_remesh)}}))
"""


def measure(tree: Path, scene: str, n: int, threads: int, particle_steps: float) -> dict:
    """One fresh-process measurement of ``scene`` with ``n`` particles on ``threads`` threads."""
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS=str(threads))
    code = SCENES.format(scene=scene, n=n, particle_steps=particle_steps)
    done = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: measurement failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_threads", description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="another checkout, measured on 1 thread (its serial kernel)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sizes", nargs="+", default=list(DEFAULT_SIZES), choices=list(SIZES))
    parser.add_argument("--scenes", nargs="+", default=["beam", "column"], choices=["beam", "column"])
    parser.add_argument("--particle-steps", type=float, default=3e7, help="work per measurement (default 3e7)")
    args = parser.parse_args(argv)
    configs = {"1 thread": (ROOT, 1), "2 threads": (ROOT, 2)}
    if args.compare:
        configs["other"] = (args.compare.resolve(), 1)
    for tree, threads in dict.fromkeys(configs.values()):  # fill every tree's numba cache
        measure(tree, "beam", 2000, threads, 1e5)
    print(f"{'scene':>6} {'particles':>9}" + "".join(f" {label:>10}" for label in configs)
          + f" {'2/1':>6}" + (f" {'2/other':>8}" if args.compare else "")
          + "   (M particle-steps/s, medians of alternated fresh processes)")
    for scene in args.scenes:
        one_thread = {}
        for size in args.sizes:
            rates: dict[str, list[float]] = {label: [] for label in configs}
            n = 0
            for _ in range(args.repeats):
                for label, (tree, threads) in configs.items():
                    result = measure(tree, scene, SIZES[size], threads, args.particle_steps)
                    n = result["n"]
                    rates[label].append(result["rate"])
            medians = {label: statistics.median(values) for label, values in rates.items()}
            one_thread[n] = medians["1 thread"]
            row = f"{scene:>6} {n:9d}" + "".join(f" {m / 1e6:10.2f}" for m in medians.values())
            row += f" {medians['2 threads'] / medians['1 thread']:6.2f}"
            if args.compare:
                row += f" {medians['2 threads'] / medians['other']:8.2f}"
            print(row, flush=True)
        if len(one_thread) > 1:
            small, large = min(one_thread), max(one_thread)
            print(f"{scene:>6} one-thread cost per particle-step, {large} over {small} particles: "
                  f"{one_thread[small] / one_thread[large]:.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
