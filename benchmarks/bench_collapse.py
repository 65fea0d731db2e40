"""Throughput with plasticity and remeshing: the two collapse scenes.

    python -m benchmarks.bench_collapse                    # granular h = 4 mm, cohesive h = 0.04 m
    python -m benchmarks.bench_collapse --granular-h 0.002 --cohesive-h 0.02

For the collapse stage of each study (after its gravity stage): particle-steps per second,
number of mesh rebuilds, and the share of the stage's wall time spent rebuilding meshes
(Delaunay + alpha shape + adjacency + crowded-particle smoothing + quality).  Warm cache.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from spfem_core.simulation import Simulation
from workflows.scene import build_scene, solver_settings
from workflows.stages.running import begin_stage
from workflows.study import parse_study

ROOT = Path(__file__).resolve().parents[1]


def collapse_stage(study_file: str, spacing_m: float) -> dict:
    text = (ROOT / "studies" / study_file).read_text()
    default = next(line for line in text.splitlines() if line.startswith("spacing_m"))
    study = parse_study(text.replace(default, f"spacing_m = {spacing_m}"))
    sim = Simulation(build_scene(study), solver_settings(study))
    begin_stage(study, sim, 0)
    sim.relax(damping=study.stages[0].damping, tolerance=study.stages[0].tolerance,
              max_duration_s=study.stages[0].max_duration_s)
    begin_stage(study, sim, 1)
    remesh_before = sim.counters.remesh_wall_s
    start = time.perf_counter()
    series = sim.run(study.stages[1].duration_s, record_interval_s=study.stages[1].record_interval_s)
    wall = time.perf_counter() - start
    return dict(
        study=study_file, spacing_m=spacing_m, particles=sim.n_particles, steps=series.n_steps,
        rebuilds=series.n_remesh, wall_s=wall, mps=sim.n_particles * series.n_steps / wall / 1e6,
        remesh_share=(sim.counters.remesh_wall_s - remesh_before) / wall,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--granular-h", type=float, default=0.004)
    parser.add_argument("--cohesive-h", type=float, default=0.04)
    args = parser.parse_args()
    rows = [collapse_stage("collapse_granular.toml", args.granular_h),
            collapse_stage("collapse_cohesive.toml", args.cohesive_h)]
    print(f"{'study':>24} {'h (m)':>7} {'particles':>9} {'steps':>7} {'rebuilds':>8} {'wall (s)':>8} "
          f"{'Mparticle-steps/s':>17} {'remesh share':>12}")
    for r in rows:
        print(f"{r['study']:>24} {r['spacing_m']:7.3f} {r['particles']:9d} {r['steps']:7d} {r['rebuilds']:8d} "
              f"{r['wall_s']:8.1f} {r['mps']:17.2f} {r['remesh_share']:12.1%}")


if __name__ == "__main__":
    main()
