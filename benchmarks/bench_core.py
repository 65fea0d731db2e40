"""Core throughput: particle-steps per second, with and without stabilisation, and compile/start-up times.

    python -m benchmarks.bench_core                          # the elastic beam: 1k, 10k, 40k, 100k particles, beta 0.1 and 0
    python -m benchmarks.bench_core --scene column           # a plastic sand column flowing on a rough floor
    python -m benchmarks.bench_core --quick                  # one repeat per size
    python -m benchmarks.bench_core --compare ../other-tree  # this tree against another checkout, alternated

Every measurement runs in a fresh process with the tree's own sources on the path and a warm
numba cache, built from core calls that every version has.  **beam**: the elastic cantilever
(verification.scenes), one warm-up call, then a fixed number of steps (about a second) timed
``repeats`` times.  **column**: Mohr-Coulomb sand (c = 0, phi = 30 deg) released on a rough
floor against a smooth wall: every particle yields, the walls act and the mesh is rebuilt as
it flows (the scene of a collapse or an SRF run past failure); the code is warmed on a small
copy, then the same steps from the release are timed once per process.  The median is quoted,
and the throughput with stabilisation over that without it at each size.  With ``--compare`` the two trees alternate measurement by
measurement, so that a machine whose speed drifts treats both alike, and the ratio is printed.
Cold compile: a fresh process with an empty cache (import, mesh, one compiled call).  Warm
start: the same with that cache filled.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPACINGS_M = {"1k": 0.02, "10k": 0.02 / 10**0.5, "40k": 0.02 / 40**0.5, "100k": 0.02 / 100**0.5}

BEAM = """
import numpy as np
from spfem_core.cloud import particles_in_polygon
from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.simulation import Simulation

def beam(h, beta):
    xy = particles_in_polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]], h)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("beam", 1850.0, 80e6, 0.25), h,
                  gravity_m_s2=[0.0, -9.8])
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=beta))
"""

SAND_COLUMN = """
import numpy as np
from spfem_core.cloud import particles_in_polygon
from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.simulation import Simulation

def sand_column(h, beta):
    xy = particles_in_polygon([[0.0, 0.0], [0.2, 0.0], [0.2, 0.4], [0.0, 0.4]], h)
    sand = MaterialTable.single("sand", "mohr_coulomb", 2000.0, 5e6, 0.3, 0.0, 30.0, 0.0)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), sand, h, gravity_m_s2=[0.0, -9.81])
    scene.add_wall(-0.1, 0.0, 2.0, 0.0, friction=0.5)
    scene.add_wall(0.0, 1.0, 0.0, 0.0, friction=0.0)
    return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=beta))
"""
"""Source of the sand column (also ``bench_threads``'s): core calls every version has."""

COLUMN_THROUGHPUT = SAND_COLUMN + """
import json, time
probe = sand_column(0.0063, {beta!r})  # about 2,000 particles: the code loaded, the column itself at rest
probe.run(20 * probe.dt_s)
rates = []
for _ in range({repeats}):
    sim = sand_column({h!r}, {beta!r})
    n = sim.n_particles
    steps = max(200, int(1.5e7 / n))
    start = time.perf_counter()
    series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
    rates.append(n * series.n_steps / (time.perf_counter() - start))
print(json.dumps({{"n": n, "rates": rates}}))
"""

COLUMN_SPACINGS_M = {size: spacing * 0.2**0.5 for size, spacing in SPACINGS_M.items()}
"""The column (0.2 m x 0.4 m) has a fifth of the beam's area (2 m x 0.2 m): the same particle counts."""

THROUGHPUT = BEAM + """
import json, time
sim = beam({h!r}, {beta!r})
n = sim.n_particles
steps = max(200, int(1.5e7 / n))  # about 1 s at 15 M particle-steps/s
sim.run(20 * sim.dt_s)  # compiled code loaded, caches hot
rates = []
for _ in range({repeats}):
    start = time.perf_counter()
    series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
    rates.append(n * series.n_steps / (time.perf_counter() - start))
print(json.dumps({{"n": n, "rates": rates}}))
"""

STARTUP = """
import time
start = time.perf_counter()
""" + BEAM + """
sim = beam(0.05, 0.1)
sim.run(20 * sim.dt_s)
print(time.perf_counter() - start)
"""


def _python(tree: Path, code: str, cache_dir: str | None = None) -> str:
    """Run ``code`` in a fresh interpreter on ``tree``'s sources; its standard output."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    if cache_dir is not None:
        env["SPFEM_CACHE_DIR"] = cache_dir
    done = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: measurement failed:\n{done.stderr}")
    return done.stdout.strip().splitlines()[-1]


def throughput(tree: Path, spacing_m: float, beta: float, repeats: int, scene: str = "beam") -> tuple[int, float]:
    """(particles, median particle-steps per second) of ``scene`` on ``tree``."""
    code = (THROUGHPUT if scene == "beam" else COLUMN_THROUGHPUT).format(h=spacing_m, beta=beta, repeats=repeats)
    result = json.loads(_python(tree, code))
    return result["n"], statistics.median(result["rates"])


def startup_seconds(tree: Path) -> tuple[float, float]:
    """(cold compile + first call, median warm start of 3) in fresh processes."""
    with tempfile.TemporaryDirectory() as cache:
        cold = float(_python(tree, STARTUP, cache))
        warm = statistics.median(float(_python(tree, STARTUP, cache)) for _ in range(3))
    return cold, warm


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_core", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat per size")
    parser.add_argument("--scene", choices=("beam", "column"), default="beam",
                        help="the elastic beam (default) or the plastic sand column")
    parser.add_argument("--no-startup", action="store_true", help="skip the cold-compile and warm-start times")
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos to measure alongside this one")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else 3
    trees = {"this": ROOT} | ({"other": args.compare.resolve()} if args.compare else {})

    spacings = SPACINGS_M if args.scene == "beam" else COLUMN_SPACINGS_M
    for label, tree in trees.items():
        _python(tree, THROUGHPUT.format(h=0.05, beta=0.1, repeats=1))  # fill the tree's numba cache
        if not args.no_startup:
            cold, warm = startup_seconds(tree)
            print(f"{label} ({tree}): numba cold compile + first call {cold:.2f} s, warm start {warm:.2f} s")

    header = f"{'particles':>9} {'beta':>5}" + "".join(f" {label + ' M/s':>12} {'ns/step':>8}" for label in trees)
    print(header + f" {'cost vs 1k':>10}" + (f" {'this/other':>10}" if len(trees) == 2 else "")
          + "   (M particle-steps/s, medians)")
    this_rate: dict[tuple[int, float], float] = {}
    for beta in (0.1, 0.0):
        first_ns = None
        for size, spacing in spacings.items():
            rates: dict[str, list[float]] = {label: [] for label in trees}
            n = 0
            for _ in range(repeats):  # alternate the trees run by run
                for label, tree in trees.items():
                    n, rate = throughput(tree, spacing, beta, 1, args.scene)
                    rates[label].append(rate)
            medians = {label: statistics.median(values) for label, values in rates.items()}
            this_rate[(size, beta)] = medians["this"]
            row = f"{n:9d} {beta:5.2f}" + "".join(f" {m / 1e6:12.2f} {1e9 / m:8.1f}" for m in medians.values())
            first_ns = first_ns or 1e9 / medians["this"]
            row += f" {1e9 / medians['this'] / first_ns:10.2f}"
            if len(trees) == 2:
                row += f" {medians['this'] / medians['other']:10.3f}"
            print(row, flush=True)
    print("with stabilisation / without (this tree): " + ", ".join(
        f"{size} {this_rate[(size, 0.1)] / this_rate[(size, 0.0)]:.2f}" for size in spacings))
    return 0


if __name__ == "__main__":
    sys.exit(main())
