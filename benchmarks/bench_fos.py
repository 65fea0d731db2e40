"""The factor-of-safety workflow end to end: wall time, its shares, and the FOS.

    python -m benchmarks.bench_fos                       # reference slope, h = 0.3 m, 2 then 1 worker
    python -m benchmarks.bench_fos --spacing 1.0 0.5 0.3 --workers 2
    python -m benchmarks.bench_fos --spacing 0.3 --fit inner --workers 2
    python -m benchmarks.bench_fos --repeat 3 --timeline # 2 and 1 workers three times, medians
    python -m benchmarks.bench_fos --ceiling             # the machine's own 2-process speed-up

Each case runs ``spfem-fos`` in a fresh process on a fresh output folder and, unless
``--warm`` is given, a fresh numba cache (so the time includes compilation), then reads the
FOS and the time shares from ``summary.nc``: gravity, SRF runs (elapsed, and the summed
worker time), remeshing inside the runs, and file writing.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import xarray as xr

from spfem_core.warmup import warm_up
from workflows.fos.gravity import run_gravity
from workflows.fos.task import run_srf

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "reference_slope.toml"
FITS = {"mc": "mohr_coulomb_match", "inner": "inner", "outer": "outer"}


def run_case(spacing_m: float, fit: str, workers: int, warm: bool, scratch: Path) -> dict:
    text = STUDY.read_text()
    text = text.replace("spacing_m = 0.3", f"spacing_m = {spacing_m}")
    text = text.replace('dp_fit = "mohr_coulomb_match"', f'dp_fit = "{FITS[fit]}"')
    case = scratch / f"h{spacing_m}_{fit}_w{workers}"
    case.mkdir(parents=True)
    study = case / "study.toml"
    study.write_text(text)
    env = dict(os.environ)
    if not warm:
        env["SPFEM_CACHE_DIR"] = str(case / "numba-cache")
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "workflows.cli", str(study), "--out", str(case / "out"), "--workers", str(workers),
         "--quiet"],
        capture_output=True, text=True, env=env, cwd=ROOT,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"case h={spacing_m} fit={fit} workers={workers} failed:\n{done.stderr}")
    with xr.open_dataset(case / "out" / "summary.nc") as summary:
        fos = summary["fos"]
        start, end = summary["run_start"].values, summary["run_end"].values
        span = float(end.max() - start.min())  # first run start to last run end, on the workers
        timeline = sorted(zip(start, end, summary["srf"].values, summary["status"].values))
        return dict(
            span=span, busy=float((end - start).sum()) / (workers * span), first_start=float(start.min()),
            last_end=float(end.max()), timeline=timeline,
            spacing=spacing_m, fit=fit, workers=workers, wall=wall, fos=float(fos), low=fos.attrs["fos_low"],
            high=fos.attrs["fos_high"], runs=summary.sizes["srf"], particles=summary.attrs["n_particles"],
            agree=fos.attrs["criteria_agree"],
            **{key[5:-2]: float(value) for key, value in summary.attrs.items() if key.startswith("time_")},
        )


def _timed_run(args) -> float:
    """Wall seconds of one SRF run in this (pool) process, after loading the compiled kernels."""
    study_text, gravity, srf = args
    warm_up()
    start = time.perf_counter()
    run_srf(study_text, gravity, srf)
    return time.perf_counter() - start


def machine_ceiling(spacing_m: float, srf: float, repeats: int) -> None:
    """How much faster two independent processes finish two identical SRF runs than one process
    finishes them one after the other: the best any 2-worker study can do on this machine."""
    text = STUDY.read_text().replace("spacing_m = 0.3", f"spacing_m = {spacing_m}")
    job = (text, run_gravity(text, threads=0).state, srf)
    ratios = []
    with ProcessPoolExecutor(max_workers=2) as pool:
        list(pool.map(_timed_run, [job, job]))  # both processes load the kernels
        for _ in range(repeats):
            alone = pool.submit(_timed_run, job).result()
            start = time.perf_counter()
            pair = list(pool.map(_timed_run, [job, job]))
            both = time.perf_counter() - start
            ratios.append(2.0 * alone / both)
            print(f"one run alone {alone:.1f} s; two at once {pair[0]:.1f} / {pair[1]:.1f} s each, {both:.1f} s for "
                  f"both: 2 processes are {ratios[-1]:.2f}x faster than 1", flush=True)
    print(f"machine ceiling (median of {repeats}): {statistics.median(ratios):.2f}x", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.3])
    parser.add_argument("--fit", choices=sorted(FITS), nargs="+", default=["mc"])
    parser.add_argument("--workers", type=int, nargs="+", default=[2, 1])
    parser.add_argument("--timeline", action="store_true", help="print when each run started and ended")
    parser.add_argument("--repeat", type=int, default=1,
                        help="run every case this many times, the worker counts interleaved; medians are compared")
    parser.add_argument("--ceiling", action="store_true",
                        help="only measure the machine's own 2-process speed-up on identical SRF runs")
    parser.add_argument("--warm", action="store_true", help="reuse the numba cache (no compilation in the time)")
    args = parser.parse_args()
    if args.ceiling:
        machine_ceiling(args.spacing[0], 1.3, max(args.repeat, 3))
        return
    if args.warm:  # fill the cache first, or the first case compiles (the cache is keyed on the core's sources)
        subprocess.run([sys.executable, "-c", "from spfem_core.warmup import warm_up; warm_up()"], check=True, cwd=ROOT)
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for spacing in args.spacing:
            for fit in args.fit:
                for repeat, workers in [(r, w) for r in range(args.repeat) for w in args.workers]:
                    row = run_case(spacing, fit, workers, args.warm, Path(scratch) / f"repeat{repeat}")
                    rows.append(row)
                    print(
                        f"h {spacing:4.2f} m  fit {fit:5s}  workers {workers}  particles {row['particles']:6d}  "
                        f"FOS {row['fos']:.4f} [{row['low']:.4f}, {row['high']:.4f}]  runs {row['runs']:2d}  "
                        f"agree {row['agree']}  wall {row['wall']:6.1f} s  (gravity {row['gravity']:.1f} s, "
                        f"SRF runs {row['srf_runs_elapsed']:.1f} s elapsed / {row['srf_runs_worker']:.1f} s on workers, "
                        f"remeshing {row['remeshing']:.1f} s, I/O {row['io']:.1f} s)",
                        flush=True,
                    )
                    print(
                        f"    first run starts at {row['first_start']:.1f} s, last ends at {row['last_end']:.1f} s; "
                        f"workers busy {100 * row['busy']:.0f}% of that span",
                        flush=True,
                    )
                    if args.timeline:
                        for start, end, srf, status in row["timeline"]:
                            print(f"      {start:7.2f} - {end:7.2f} s  SRF {srf:.4f}  {status}")
    walls: dict[tuple, list[float]] = {}
    for r in rows:
        walls.setdefault((r["spacing"], r["fit"], r["workers"]), []).append(r["wall"])
    median = {case: statistics.median(values) for case, values in walls.items()}
    for (spacing, fit, workers), wall in median.items():
        if workers == 1 and (spacing, fit, 2) in median:
            print(
                f"h {spacing} m fit {fit}: median wall {median[(spacing, fit, 2)]:.1f} s on 2 workers, {wall:.1f} s on 1 "
                f"({len(walls[(spacing, fit, 1)])} runs each): 2 workers are {wall / median[(spacing, fit, 2)]:.3f}x "
                "faster than 1"
            )


if __name__ == "__main__":
    main()
