"""What a strength-reduction study costs besides its runs' steps, part by part, each part timed in
a fresh process and the least of ``--repeats`` kept (the shared machine's load only ever adds):

    python -m benchmarks.startup_parts
    python -m benchmarks.startup_parts --study reference_slope --repeats 5

The parts of the study's start (in the order a run pays them; the cluster starts in a thread while
this process builds the scene and relaxes gravity, so the start costs the larger of the two):

- interpreter: ``python -c pass``;
- imports: the modules a study run imports (the command's, the study's, dask's, the core's);
- numba cache load: ``spfem_core.warmup.warm_up`` after the imports (the compiled loop from the disk cache);
- cluster start: a local cluster of 2 single-thread workers and its client, then closed;
- scene: the study's particles, materials, supports, water (``scene.scene_and_flow``);
- limit-equilibrium estimate: ``fos.critical_circle.critical_circle(quick=True)`` (a sweep's or a
  probabilistic study's prediction asks it of every case);
- gravity: the study's stages before the strength reduction (``fos.gravity.run_gravity``, one thread).

Then the study itself run as a user runs it (2 local workers), ``--repeats`` times: its wall W, the
summary's SRF search elapsed E and its runs' worker time C (``time_srf_runs_elapsed_s``,
``time_srf_runs_worker_s``) and its runs R, so that

    fixed = W - E                     (everything but the search: ``workflows.check.STARTUP_S``)
    per run = (2 E - C) / R           (a run's slot on a worker besides its steps: many cases'
                                       searches at once, ``--study sweep_strength``,
                                       ``SEARCH_RUN_OVERHEAD_S``)

and the runs' steps S with C / S against ``STEP_OVERHEAD_S + N SECONDS_PER_PARTICLE_STEP``.  Each
row the least of the repeats.  The figures of a case once pyplot is loaded (``fos.figures.draw_figures``
on the study's results, the second of two).

A lone search (a single study) keeps fewer than its 2 workers busy: it runs what its last runs
decided, and one worker idles while the other finishes the run it waits for, for longer the longer
its runs.  Its elapsed time E = C / P + R a; the fit of P (``LONE_SEARCH_WORKERS``) and a
(``LONE_RUN_WAIT_S``) by least squares through single studies of short and long runs, each run
``--repeats`` times (the repeat of least wall kept):

    python -m benchmarks.startup_parts --lone quickstart published/griffiths_lane_ex4

Whether the limit-equilibrium estimates of a study's predictions hold up its wall:

    python -m benchmarks.startup_parts --estimates probabilistic_c_phi

runs the study in this process (2 workers) with the estimates computed as the study asks them
(``fos.critical_circle.critical_circle``; their count, thread time and wall summed) and with the same
estimates remembered from the run before, alternately, ``--repeats`` times each: the same windows, runs
and FOS, the walls differing by what the estimates cost the study.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
WORKERS = 2

PARTS = r"""
import json, sys, time
from pathlib import Path
start = time.perf_counter()
marks = {}
import workflows.cli, workflows.study_types, workflows.fos.engine, workflows.fos.cluster, workflows.fos.summary
import workflows.fos.figures, spfem_core.simulation, distributed
marks["imports"] = time.perf_counter() - start
from spfem_core.warmup import warm_up
t = time.perf_counter(); warm_up(); marks["numba cache load"] = time.perf_counter() - t
from workflows.study import load_study
from workflows.scene import scene_and_flow
from workflows.fos.critical_circle import critical_circle
from workflows.fos.gravity import run_gravity
path = Path(sys.argv[1])
study = load_study(path)
t = time.perf_counter(); scene_and_flow(study); marks["scene"] = time.perf_counter() - t
t = time.perf_counter(); critical_circle(study, quick=True); marks["limit-equilibrium estimate"] = time.perf_counter() - t
t = time.perf_counter(); run_gravity(path.read_text(), threads=1); marks["gravity"] = time.perf_counter() - t
from workflows.fos.cluster import close_client, start_client
t = time.perf_counter(); client, cluster = start_client(2, None); marks["cluster start"] = time.perf_counter() - t
t = time.perf_counter(); close_client(client, cluster); marks["cluster close"] = time.perf_counter() - t
print(json.dumps(marks))
"""


def parts_once(study_path: Path) -> dict[str, float]:
    """Every part of the module doc, in fresh processes (seconds)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    interpreter_s = time.perf_counter() - start
    done = subprocess.run([sys.executable, "-c", PARTS, str(study_path)], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(done.stderr[-2000:])
    return {"interpreter": interpreter_s, **json.loads(done.stdout.splitlines()[-1])}


def study_once(study_path: Path) -> dict[str, float]:
    """The study run as a user runs it: W, E, C, R and the runs' steps (module doc; a study of many
    cases: E from the first run's start to the last one's end, over every case's summary.nc)."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study_path), "--out", out, "--quiet",
                               "--workers", str(WORKERS)], cwd=ROOT, capture_output=True, text=True)
        wall_s = time.perf_counter() - start
        if done.returncode != 0:
            raise SystemExit(done.stderr[-2000:])
        starts, ends, found = [], [], {"wall": wall_s, "runs' worker time": 0.0, "runs": 0, "steps": 0, "particles": 0}
        for summary in sorted(Path(out).rglob("summary.nc")):
            with xr.open_dataset(summary) as ds:
                began, took = ds["run_start"].values, ds["wall_time"].values
                starts.append(float(began.min()))
                ends.append(float((began + took).max()))
                found["runs' worker time"] += float(took.sum())
                found["runs"] += int(ds.sizes["srf"])
                found["steps"] += int(ds["n_steps"].sum())
                found["particles"] = int(ds.attrs["n_particles"])
        found["search elapsed"] = max(ends) - min(starts)
        return found


def figures_s(study_path: Path) -> tuple[float, float]:
    """The second drawing of the study's figures (pyplot loaded by the first): (wall, processor) seconds."""
    from workflows.fos.figures import draw_figures

    with tempfile.TemporaryDirectory() as out:
        subprocess.run([sys.executable, "-m", "workflows.cli", str(study_path), "--out", out, "--quiet"], cwd=ROOT,
                       capture_output=True, text=True, check=True)
        with xr.open_dataset(Path(out) / "summary.nc") as summary:
            summary = summary.load()
        draw_figures(Path(out), summary)
        start, cpu = time.perf_counter(), time.process_time()
        draw_figures(Path(out), summary)
        return time.perf_counter() - start, time.process_time() - cpu


def estimates_on_the_wall(study_path: Path, repeats: int) -> None:
    """The ``--estimates`` comparison of the module doc."""
    import workflows.fos.critical_circle as circles
    from workflows.cases import RunOptions
    from workflows.study import load_study
    from workflows.study_types import run_study

    computed = circles.critical_circle
    memo: dict = {}
    spent: list[tuple[float, float]] = []

    def key(study, quick):
        return (study.geometry, study.materials, study.water, study.loads, study.seepage, quick)

    def computing(study, quick=False):
        cpu, wall = time.thread_time(), time.perf_counter()
        memo[key(study, quick)] = computed(study, quick=quick)
        spent.append((time.thread_time() - cpu, time.perf_counter() - wall))
        return memo[key(study, quick)]

    study = load_study(study_path)
    rows = [("computed (warm-up, not counted)", computing)] + [("computed", computing), ("remembered",
            lambda study, quick=False: memo[key(study, quick)])] * repeats
    with tempfile.TemporaryDirectory() as out:
        for label, function in rows:
            circles.critical_circle = function
            spent.clear()
            start = time.perf_counter()
            run_study(study, Path(out) / "study", RunOptions(workers=WORKERS, force=True))
            print(f"{label}: wall {time.perf_counter() - start:.2f} s; {len(spent)} estimates, thread time "
                  f"{sum(s[0] for s in spent):.2f} s, wall {sum(s[1] for s in spent):.2f} s", flush=True)
    circles.critical_circle = computed


def lone_searches(names: list[str], repeats: int) -> None:
    """The ``--lone`` fit of the module doc: E, C and R of each study, then P and a."""
    import numpy as np

    from workflows.check import LONE_RUN_WAIT_S, LONE_SEARCH_WORKERS

    rows = []
    print("| study | particles | wall W (s) | search E (s) | runs' worker time C (s) | runs R |")
    print("|---|---|---|---|---|---|")
    for name in names:
        found = min((study_once(ROOT / "studies" / f"{name}.toml") for _ in range(repeats)), key=lambda r: r["wall"])
        worker_s = found["runs' worker time"]
        rows.append((worker_s, found["runs"], found["search elapsed"]))
        print(f"| {name} | {found['particles']} | {found['wall']:.2f} | {found['search elapsed']:.2f} | "
              f"{worker_s:.2f} | {found['runs']} |", flush=True)
    (inverse_p, wait_s), *_ = np.linalg.lstsq(np.array([[c, r] for c, r, _ in rows]), np.array([e for *_, e in rows]),
                                              rcond=None)
    print(f"\nE = C / P + R a: P = {1.0 / inverse_p:.2f} workers (LONE_SEARCH_WORKERS {LONE_SEARCH_WORKERS}), "
          f"a = {wait_s:.3f} s (LONE_RUN_WAIT_S {LONE_RUN_WAIT_S})")


def main(argv=None) -> int:
    from workflows.check import (
        FIGURES_S,
        SEARCH_RUN_OVERHEAD_S,
        SECONDS_PER_PARTICLE_STEP,
        STARTUP_S,
        STEP_OVERHEAD_S,
    )

    parser = argparse.ArgumentParser(prog="python -m benchmarks.startup_parts", description=__doc__.splitlines()[0])
    parser.add_argument("--study", default="quickstart", help="a strength-reduction study of studies/")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--estimates", metavar="STUDY", help="the study's walls with and without its estimates")
    parser.add_argument("--lone", nargs="+", metavar="STUDY", help="single studies: the fit of a lone search's time")
    args = parser.parse_args(argv)
    if args.lone:
        lone_searches(args.lone, args.repeats)
        return 0
    if args.estimates:
        estimates_on_the_wall(ROOT / "studies" / f"{args.estimates}.toml", args.repeats)
        return 0
    study_path = ROOT / "studies" / f"{args.study}.toml"
    parts = [parts_once(study_path) for _ in range(args.repeats)]
    runs = [study_once(study_path) for _ in range(args.repeats)]
    print(f"{args.study}, the least of {args.repeats} fresh processes each:\n")
    print("| part | seconds |")
    print("|---|---|")
    for name in parts[0]:
        print(f"| {name} | {min(p[name] for p in parts):.2f} |")
    least = {name: min(r[name] for r in runs) for name in runs[0]}
    fixed_s = min(r["wall"] - r["search elapsed"] for r in runs)
    per_run_s = min((WORKERS * r["search elapsed"] - r["runs' worker time"]) / r["runs"] for r in runs)
    step_s = min(r["runs' worker time"] / r["steps"] for r in runs)
    model_step_s = STEP_OVERHEAD_S + least["particles"] * SECONDS_PER_PARTICLE_STEP
    print(f"\nthe study on {WORKERS} workers: wall {least['wall']:.2f} s, search {least['search elapsed']:.2f} s, "
          f"{least['runs']} runs of {least['steps']} steps in all, {least['particles']} particles")
    print(f"fixed = W - E: {fixed_s:.2f} s (STARTUP_S {STARTUP_S})")
    print(f"per run = (2 E - C) / R: {per_run_s:.3f} s (many cases' searches at once, SEARCH_RUN_OVERHEAD_S "
          f"{SEARCH_RUN_OVERHEAD_S}; a lone search: --lone)")
    print(f"a step: {step_s * 1e6:.1f} us measured, {model_step_s * 1e6:.1f} us by the model")
    if (ROOT / "studies" / f"{args.study}.toml").read_text().find("[sweep]") < 0:
        drawn = [figures_s(study_path) for _ in range(args.repeats)]
        print(f"figures of a case: wall {min(d[0] for d in drawn):.2f} s, processor {min(d[1] for d in drawn):.2f} s "
              f"(FIGURES_S {FIGURES_S})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
