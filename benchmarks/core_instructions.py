"""Core cost in instructions: the elastic beam's step counted under valgrind, independent of load.

    python -m benchmarks.core_instructions --compare ../other-tree          # 1k and 10k, beta 0.1 and 0
    python -m benchmarks.core_instructions --compare ../other-tree --sizes 1k 10k 40k --steps 40
    python -m benchmarks.core_instructions --base --sizes 10k        # a block on a fixed and on a sliding base

Wall-clock throughput (``benchmarks.bench_core``) is noise on a loaded machine; the number of
instructions a step executes is not.  For each tree, a fresh process with that tree's sources
first on the path builds the elastic cantilever of ``bench_core`` (same source, same spacings) at
each size and beta, warms it up, then runs ``steps`` and ``2 * steps`` steps, each as one call of
``Simulation.run`` with one record interval (one compiled call).  Callgrind counts instructions
only inside those two calls (``--collect-atstart=no``, switched on and off around each call by
callgrind's client requests through a tiny C helper loaded with ctypes, built here with gcc from
valgrind's ``callgrind.h``); their difference over ``steps * particles`` is the cost of one
particle-step, with the call's fixed cost (Python, the set-up of the compiled call) cancelled.
The same process is first run without valgrind, which fills the tree's numba cache (the
client requests do nothing outside valgrind), in a cache directory of these runs: numba compiles
for a fixed CPU (:data:`CPU_NAME`, AVX2 and FMA, what valgrind runs) instead of the host's, so
the code counted is the code the warm-up compiled and both trees are compiled alike.  Both trees run with NUMBA_NUM_THREADS=1: the
one-thread kernels (the only ones a dask worker runs), and no thread pool whose spinning would
make the counts depend on the scheduling.  Ratio other / this: at least 1.0 when this tree
executes no more instructions per particle-step than the other one.

With ``--base``, a block in place of the cantilever: the beam's rectangle of Mohr-Coulomb soil (c 10
kPa, phi 30 deg) under gravity on its base, the base's particles held in both directions (``fixed``)
or held normal to it and sliding along it on the soil's strength (``sliding``, a slip support as a
slope's default rigid base).  The
difference of the two is what the general leapfrog costs a slope that slides on its base.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.bench_core import BEAM, SPACINGS_M

ROOT = Path(__file__).resolve().parents[1]
CACHE_DIR = Path(tempfile.gettempdir()) / "spfem-core-instructions-numba"
"""The numba cache of these runs (each tree's sources hash to their own directory below it)."""
CPU_NAME = "haswell"
CPU_FEATURES = ("+64bit,+aes,+avx,+avx2,+bmi,+bmi2,+cmov,+cx16,+cx8,+f16c,+fma,+fxsr,+lzcnt,+mmx,+movbe,"
                "+pclmul,+popcnt,+sahf,+sse,+sse2,+sse3,+sse4.1,+sse4.2,+ssse3,+xsave")
"""The code numba generates, the same with and without valgrind (which has no AVX-512 and reports
other CPU features, so that the host's cached code would neither load nor run under it)."""

CALLGRIND_HELPER_C = r"""
#include <valgrind/callgrind.h>
void start_instrumentation(void) { CALLGRIND_START_INSTRUMENTATION; }
void collect_toggle(void) { CALLGRIND_TOGGLE_COLLECT; }
void dump_stats(const char *label) { CALLGRIND_DUMP_STATS_AT(label); }
void zero_stats(void) { CALLGRIND_ZERO_STATS; }
"""

BLOCK = """
import numpy as np
from spfem_core.cloud import particles_in_polygon
from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.simulation import Simulation

def block(h, beta, base):
    xy = particles_in_polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]], h)
    soil = MaterialTable.single("soil", "mohr_coulomb", 2000.0, 50e6, 0.3, 10e3, 30.0, 0.0)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), soil, h, gravity_m_s2=[0.0, -9.81])
    on_base = scene.select_box(y_max=0.0)
    if base == "fixed":
        scene.fix(on_base, vx_m_s=0.0, vy_m_s=0.0)
    else:  # held normal to the base, sliding along it on the soil's strength (a slip support)
        scene.fix(on_base, vy_m_s=0.0)
        scene.node_slip_length_m = np.where(np.isin(np.arange(len(xy)), on_base), h, 0.0)
        scene.node_slip_side = np.where(np.isin(np.arange(len(xy)), on_base), -1.0, 0.0)
    return Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=beta))
"""
"""A block of soil on its base, fixed or sliding (module doc, ``--base``)."""

LEAPFROG_ALONE = """
from spfem_core.integration import leapfrog
from spfem_core.stage_loop import _step_parameters
for h, beta, label in {cases!r}:
    sim = block(h, beta, label.split('_')[0])
    sim.run(20 * sim.dt_s)
    nodes, params = sim.nodes, _step_parameters(sim, 0.0, 0.0)
    inertia = nodes.inertia_kg[:0] if params.inertia_is_mass else nodes.inertia_kg
    slip_nodes = np.nonzero(nodes.slip[:, 2])[0]
    args = (nodes.xy_m, nodes.displacement_m, nodes.velocity_m_s, sim.scratch.force_n, nodes.mass_kg, inertia,
            nodes.fixed, nodes.fixed_velocity_m_s, nodes.slip, slip_nodes, params.gravity_m_s2, 0.7, params.dt_s, sim.walls.xy_m,
            sim.walls.friction, params.spacing_m, sim.scratch.contact, sim.scratch.leapfrog_out, params.n_threads)
    leapfrog(*args)
    for steps in ({steps}, 2 * {steps}):
        callgrind.collect_toggle()
        for _ in range(steps):
            leapfrog(*args)
        callgrind.collect_toggle()
        callgrind.dump_stats(f"leapfrog_{{label}} n={{sim.n_particles}} steps={{steps}}".encode())
"""
"""With ``--base``: the leapfrog alone (``integration.leapfrog``, as ``stepper.advance`` calls it, damping
0.7), called from Python ``steps`` and ``2 * steps`` times after each block's steps: its share of a step."""

COUNT = """
import ctypes, sys
callgrind = ctypes.CDLL({helper!r})
for h, beta, label in {cases!r}:
    sim = {build}
    sim.run(20 * sim.dt_s)  # compiled code loaded, caches hot
    callgrind.start_instrumentation()
    callgrind.zero_stats()
    for steps in ({steps}, 2 * {steps}):
        callgrind.collect_toggle()
        series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
        callgrind.collect_toggle()
        callgrind.dump_stats(f"{{label}} n={{sim.n_particles}} steps={{series.n_steps}}".encode())
"""

_DUMP_LABEL = re.compile(r"^desc: Trigger: Client Request: (\S+) n=(\d+) steps=(\d+)$", re.M)
_DUMP_TOTAL = re.compile(r"^(?:totals|summary):\s+(\d+)", re.M)


def build_helper(directory: Path) -> Path:
    """Compile the callgrind client-request helper into ``directory``; its shared library."""
    if shutil.which("valgrind") is None or shutil.which("gcc") is None:
        raise SystemExit("core_instructions: needs valgrind and gcc on the PATH")
    source = directory / "callgrind_helper.c"
    library = directory / "callgrind_helper.so"
    source.write_text(CALLGRIND_HELPER_C)
    done = subprocess.run(["gcc", "-O1", "-shared", "-fPIC", "-o", str(library), str(source)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"core_instructions: cannot build the callgrind helper (valgrind headers?):\n{done.stderr}")
    return library


def count_instructions(tree: Path, cases: list[tuple[float, float, str]], steps: int, helper: Path,
                       out_dir: Path) -> dict[str, tuple[int, int, int]]:
    """{case label: (particles, steps counted, instructions of those steps)} for ``tree``."""
    if cases[0][2].startswith(("fixed", "sliding")):
        code = (BLOCK + COUNT.format(helper=str(helper), cases=cases, steps=steps, build="block(h, beta, label.split('_')[0])")
                + LEAPFROG_ALONE.format(cases=cases, steps=steps))
    else:
        code = BEAM + COUNT.format(helper=str(helper), cases=cases, steps=steps, build="beam(h, beta)")
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS="1", SPFEM_CACHE_DIR=str(CACHE_DIR),
               NUMBA_CPU_NAME=CPU_NAME, NUMBA_CPU_FEATURES=CPU_FEATURES)
    warm = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True)
    if warm.returncode != 0:
        raise SystemExit(f"{tree}: the run without valgrind failed:\n{warm.stderr}")
    prefix = out_dir / "callgrind.out"
    counted = subprocess.run(
        ["valgrind", "--tool=callgrind", "--instr-atstart=no", "--collect-atstart=no", f"--callgrind-out-file={prefix}.%p",
         sys.executable, "-c", code], cwd=tree, env=env, capture_output=True, text=True)
    if counted.returncode != 0:
        raise SystemExit(f"{tree}: the run under valgrind failed:\n{counted.stderr[-3000:]}")
    calls: dict[str, list[tuple[int, int, int]]] = {}
    for dump in sorted(glob.glob(f"{prefix}.*")):
        text = Path(dump).read_text(errors="replace")
        label, total = _DUMP_LABEL.search(text), _DUMP_TOTAL.search(text)
        if label is None or total is None:
            continue  # the final dump at exit, with nothing collected
        calls.setdefault(label[1], []).append((int(label[2]), int(label[3]), int(total[1])))
    result = {}
    for label, pair in calls.items():
        (n, short_steps, short_total), (_, long_steps, long_total) = sorted(pair, key=lambda call: call[1])
        result[label] = (n, long_steps - short_steps, long_total - short_total)
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.core_instructions",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos to count alongside this one")
    parser.add_argument("--sizes", nargs="+", choices=tuple(SPACINGS_M), default=["1k", "10k"])
    parser.add_argument("--steps", type=int, default=20, help="the counted calls run this many and twice as many")
    parser.add_argument("--keep", type=Path, help="keep callgrind's dumps in this directory (one per tree)")
    parser.add_argument("--base", action="store_true", help="a block on a fixed and on a sliding base (module doc)")
    args = parser.parse_args(argv)
    trees = {"this": ROOT} | ({"other": args.compare.resolve()} if args.compare else {})
    kinds = ("fixed_", "sliding_") if args.base else ("",)
    cases = [(SPACINGS_M[size], beta, f"{kind}{size}_beta{beta}") for beta in (0.1, 0.0) for size in args.sizes
             for kind in kinds]

    counts = {}
    with tempfile.TemporaryDirectory() as scratch:
        helper = build_helper(Path(scratch))
        for label, tree in trees.items():
            out_dir = (args.keep / label) if args.keep else Path(scratch) / label
            out_dir.mkdir(parents=True, exist_ok=True)
            for old in out_dir.glob("callgrind.out.*"):
                old.unlink()
            counts[label] = count_instructions(tree, cases, args.steps, helper, out_dir)
            print(f"{label}: {tree}", flush=True)

    header = f"{'scene':>16} " * args.base + f"{'particles':>9} {'beta':>5}" + "".join(f" {label + ' instr/pstep':>18}" for label in trees)
    print(header + (f" {'other/this':>10}" if len(trees) == 2 else ""))
    for _, beta, case in cases + [(None, beta, f"leapfrog_{case}") for _, beta, case in cases if args.base]:
        per_step = {}
        for label in trees:
            n, steps, instructions = counts[label][case]
            per_step[label] = instructions / (n * steps)
        scene = case.split("_")[0] + (" " + case.split("_")[1] if case.startswith("leapfrog") else "")
        row = f"{scene:>16} " * args.base + f"{n:9d} {beta:5.2f}" + "".join(f" {value:18.1f}" for value in per_step.values())
        if len(trees) == 2:
            row += f" {per_step['other'] / per_step['this']:10.3f}"
        print(row, flush=True)
    print(json.dumps({label: {case: list(value) for case, value in tree_counts.items()}
                      for label, tree_counts in counts.items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
