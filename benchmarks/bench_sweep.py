"""A sweep on one cluster: its speed-up with the workers, and the worker time it spends.

    python -m benchmarks.bench_sweep                  # studies/sweep_strength.toml (3 x 3, h = 1 m), 3 repeats
    python -m benchmarks.bench_sweep --spacing 0.5    # the same cases at h = 0.5 m (runs of about 1 s)
    python -m benchmarks.bench_sweep --study studies/sweep_geometry.toml --repeat 1

1. **Speed-up**: the sweep as a user runs it, ``spfem-fos STUDY --workers 2`` and ``--workers 1``,
   each in a fresh process on a fresh output folder (numba cache warm), alternating, ``--repeat``
   times; the medians of the command's wall time and their ratio.
2. **Worker time**: the compute time of every task the sweep ran on a local cluster of 2
   workers (gravity, runs, runs guessed ahead or cancelled: dask's task stream), against each
   case run alone as a single study on 1 worker (``workflows.study_types.run_study``: exactly the runs its search
   needs, nothing guessed; its gravity runs in the client, its wall time is added).  A strength
   sweep over an elastic gravity stage relaxes gravity once for all cases, so the table gives
   the SRF runs alone too.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from distributed import get_task_stream

from spfem_core.warmup import warm_up
from workflows.cases import RunOptions
from workflows.fos.cluster import close_client, start_client
from workflows.study import load_study
from workflows.study.reading import sweep_cases
from workflows.study_types import run_study

ROOT = Path(__file__).resolve().parents[1]


def command_wall_s(study: Path, workers: int, out: Path) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", str(out), "--workers",
                           str(workers), "--quiet"], capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{study} on {workers} workers failed:\n{done.stderr}")
    return wall


def compute_s(stream) -> tuple[float, float]:
    """(all compute time, compute time of tasks whose key starts with "gravity") in a task stream, s."""
    total = gravity = 0.0
    for task in stream.data:
        seconds = sum(s["stop"] - s["start"] for s in task["startstops"] if s["action"] == "compute")
        total += seconds
        if str(task["key"]).startswith("('gravity") or str(task["key"]).startswith("gravity"):
            gravity += seconds
    return total, gravity


def sweep_worker_s(study, out: Path) -> tuple[float, float]:
    """(compute s of every task, of the gravity tasks) of the sweep on a local cluster of 2 workers."""
    client, cluster = start_client(2, None)
    try:
        with get_task_stream(client=client) as stream:
            run_study(study, out, RunOptions(scheduler=cluster.scheduler_address))
        return compute_s(stream)
    finally:
        close_client(client, cluster)


def alone_worker_s(study, out: Path) -> tuple[float, float]:
    """(worker s, gravity s) of one case as a single study on 1 worker: its runs' compute time
    (task stream) plus its gravity stage, which a single study runs in its own process."""
    client, cluster = start_client(1, None)
    try:
        with get_task_stream(client=client) as stream:
            outcome = run_study(study, out, RunOptions(scheduler=cluster.scheduler_address))
        runs, _ = compute_s(stream)
        return runs + outcome.timings_s["gravity"], outcome.timings_s["gravity"]
    finally:
        close_client(client, cluster)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_sweep", description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=Path, default=ROOT / "studies" / "sweep_strength.toml")
    parser.add_argument("--spacing", type=float, default=None, help="geometry.spacing_m instead of the study's (m)")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each worker count (medians)")
    args = parser.parse_args(argv)
    warm_up()
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        text = args.study.read_text()
        if args.spacing is not None:
            text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {args.spacing}", text, count=1)
        args.study = scratch / args.study.name
        args.study.write_text(text)
        study = load_study(args.study)
        cases = sweep_cases(study)
        print(f"{study.name}: {len(cases)} cases, h = {study.geometry.spacing_m:g} m; {args.repeat} repeats")
        walls: dict[int, list[float]] = {2: [], 1: []}
        for r in range(args.repeat):
            for workers in (2, 1):
                walls[workers].append(command_wall_s(args.study, workers, scratch / f"w{workers}_{r}"))
        two, one = statistics.median(walls[2]), statistics.median(walls[1])
        print("\nspeed-up (spfem-fos STUDY --workers N, fresh output, warm numba cache)")
        print(f"  2 workers: median {two:.1f} s  {[round(w, 1) for w in walls[2]]}")
        print(f"  1 worker : median {one:.1f} s  {[round(w, 1) for w in walls[1]]}")
        print(f"  1 worker / 2 workers = {one / two:.2f}x")

        sweep_total, sweep_gravity = sweep_worker_s(study, scratch / "sweep")
        alone_total = alone_gravity = 0.0
        for case in cases:
            total, gravity = alone_worker_s(case.study, scratch / "alone" / case.case_id)
            alone_total, alone_gravity = alone_total + total, alone_gravity + gravity
    print("\nworker time (dask task stream): the sweep on 2 workers; each case alone as a single study on 1 worker")
    print(f"  {'':24}{'sweep':>9}{'alone':>9}{'ratio':>8}")
    print(f"  {'all tasks (s)':24}{sweep_total:9.1f}{alone_total:9.1f}{sweep_total / alone_total:8.3f}")
    print(f"  {'gravity (s)':24}{sweep_gravity:9.1f}{alone_gravity:9.1f}")
    sweep_runs, alone_runs = sweep_total - sweep_gravity, alone_total - alone_gravity
    print(f"  {'SRF runs (s)':24}{sweep_runs:9.1f}{alone_runs:9.1f}{sweep_runs / alone_runs:8.3f}")


if __name__ == "__main__":
    main()
