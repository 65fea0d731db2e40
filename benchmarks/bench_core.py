"""Core throughput: particle-steps per second of the elastic beam, and compile/start-up times.

    python benchmarks/bench_core.py            # 1k, 10k and 40k particles, beta = 0.1 and 0
    python benchmarks/bench_core.py --quick    # fewer repeats

Single process, warm numba cache, gradients recomputed every step.  Each size runs a fixed
number of steps (about a second of wall time) three times after a warm-up; medians are quoted.
Cold compile: a fresh process with an empty cache dir (import, mesh, one compiled call).
Warm start: the same in a fresh process with that cache filled.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

STARTUP_SNIPPET = """
import time
t0 = time.perf_counter()
import sys; sys.path.insert(0, {tests!r}); sys.path.insert(0, {root!r})
from conftest import beam_scene
from spfem_core.scene import SolverSettings
from spfem_core.simulation import Simulation
sim = Simulation(beam_scene(0.05), SolverSettings(cfl=0.5, stabilisation_beta=0.1))
sim.run(20 * sim.dt_s)
print(time.perf_counter() - t0)
"""


def startup_seconds(cache_dir: str) -> float:
    env = dict(os.environ, SPFEM_CACHE_DIR=cache_dir)
    code = STARTUP_SNIPPET.format(tests=str(ROOT / "tests"), root=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def throughput(spacing_m: float, beta: float, repeats: int) -> tuple[int, float]:
    from conftest import beam_scene

    from spfem_core.scene import SolverSettings
    from spfem_core.simulation import Simulation

    sim = Simulation(beam_scene(spacing_m), SolverSettings(cfl=0.5, stabilisation_beta=beta))
    n = sim.n_particles
    steps = max(200, int(1.5e7 / n))  # ~1 s at 15 M particle-steps/s
    sim.run(20 * sim.dt_s)  # warm-up (compiled code loaded, caches hot)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
        elapsed = time.perf_counter() - start
        rates.append(n * series.n_steps / elapsed)
    return n, statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="one repeat per size")
    args = parser.parse_args()
    repeats = 1 if args.quick else 3

    with tempfile.TemporaryDirectory() as cache:
        cold = startup_seconds(cache)
        warm = statistics.median(startup_seconds(cache) for _ in range(3))
    print(f"numba cold compile + first call: {cold:6.2f} s   warm start (cache filled): {warm:5.2f} s")

    print(f"{'particles':>9} {'beta':>5} {'Mparticle-steps/s':>18} {'ns/particle-step':>17} {'cost vs 1k':>10}")
    for beta in (0.1, 0.0):
        base = None
        for spacing in (0.02, 0.02 / np.sqrt(10.0), 0.01):
            n, rate = throughput(spacing if spacing != 0.01 else 0.02 / np.sqrt(40.0), beta, repeats)
            cost_ns = 1e9 / rate
            base = base or cost_ns
            print(f"{n:9d} {beta:5.2f} {rate / 1e6:18.2f} {cost_ns:17.1f} {cost_ns / base:10.2f}")


if __name__ == "__main__":
    main()
