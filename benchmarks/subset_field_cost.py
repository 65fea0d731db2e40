"""A small pf on the shipped undrained random-field study: subset simulation's wall time and runs against crude
Monte Carlo's estimated cost for the same coefficient of variation.

    python -m benchmarks.subset_field_cost                                   # h = 1 m, 500 a level, factor 0.7
    python -m benchmarks.subset_field_cost --spacing 2 --samples 100 --factor 0.7 --crude 40

``studies/probabilistic_undrained.toml`` (a lognormal cu field, COV 0.5, theta = H) with ``method =
"subset_simulation"``, ``compute = "fos"`` and the ``factor`` that puts pf where it is wanted, 2 local workers.
Crude Monte Carlo's cost is estimated, not run: its realisations for subset's coefficient of variation,
(1 - pf) / (pf cov^2), at the verdict-mode rate measured here on ``--crude`` realisations of the same study
(``compute = "verdict"``, one run each at the factor).  The load average is printed before and after each:
the machine is shared.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import tempfile
import time
from pathlib import Path

from workflows.cases import RunOptions
from workflows.study import parse_study
from workflows.study_types import run_study

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "probabilistic_undrained.toml"


def study_text(spacing_m: float, factor: float, method: str, compute: str, realisations: int, samples: int,
               seed: int) -> str:
    """The shipped study at ``spacing_m`` with its [probabilistic] set (module doc); ``seed`` for its fields too."""
    text = STUDY.read_text()
    text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)
    text = re.sub(r"(?m)^method = .*$", f'method = "{method}"' + (f"\nsamples_per_level = {samples}"
                                                                  if method == "subset_simulation" else ""), text, count=1)
    text = re.sub(r"(?m)^realisations = .*$", f"realisations = {realisations}", text, count=1)
    text = re.sub(r"(?m)^compute = .*$", f'compute = "{compute}"', text, count=1)
    text = re.sub(r"(?m)^factor = .*$", f"factor = {factor:g}", text, count=1)
    return text.replace("seed = 1\n", f"seed = {seed}\n")


def level_lines(result_path: Path, level_covs: list) -> str:
    """Each level's points, SRF runs, candidates rejected by their one run at the threshold and coefficient of
    variation (from ``probabilistic.nc``): what an extrapolation to other level sizes needs."""
    import numpy as np
    import xarray as xr

    ds = xr.load_dataset(result_path)
    level, runs = ds["subset_level"].values, ds["n_runs"].values
    one_run = (ds["status"].values == "above_srf_max") & (level > 0)
    two_runs = (ds["status"].values == "no_knee") & (level > 0) & (runs == 2)
    lines = []
    for k in range(int(level.max()) + 1):
        at = level == k
        lines.append(f"level {k}: {int(at.sum())} points, {int(runs[at].sum())} SRF runs ({runs[at].mean():.2f} a point), "
                     f"{int(one_run[at].sum())} rejected by their one run at the threshold, "
                     f"{int(two_runs[at].sum())} accepted after two (stable at the guard), "
                     f"{int(np.sum(at & (ds['subset_accepted'].values == 1)))} accepted"
                     + (f", level cov {level_covs[k]:.3g}" if k < len(level_covs) else ""))
    return "\n".join(lines)


def load() -> str:
    return f"{os.getloadavg()[0]:.1f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.subset_field_cost", description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=1.0)
    parser.add_argument("--samples", type=int, default=500, help="FOS searches a level")
    parser.add_argument("--factor", type=float, default=0.7)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--crude", type=int, default=100, help="verdict-mode realisations timed for crude MC's rate")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    options = RunOptions(workers=args.workers)
    with tempfile.TemporaryDirectory() as scratch:
        before = load()
        start = time.perf_counter()
        crude = run_study(parse_study(study_text(args.spacing, args.factor, "monte_carlo", "verdict", args.crude, 0,
                                                 args.seed)), Path(scratch) / "crude", options)
        crude_wall_s = time.perf_counter() - start
        rate = crude.n_realisations / crude_wall_s
        print(f"crude Monte Carlo, verdict mode, h = {args.spacing:g} m, factor {args.factor:g}: {crude.n_realisations} "
              f"realisations ({crude.n_failed} failed) in {crude_wall_s:.0f} s, {60 * rate:.1f} a minute (load "
              f"{before} -> {load()})\n", flush=True)
        before = load()
        start = time.perf_counter()
        out = run_study(parse_study(study_text(args.spacing, args.factor, "subset_simulation", "fos", 20 * args.samples,
                                               args.samples, args.seed)), Path(scratch) / "subset", options)
        wall_s = time.perf_counter() - start
        print(level_lines(Path(scratch) / "subset" / "probabilistic.nc", out.level_covs), flush=True)
    needed = (1.0 - out.pf) / (out.pf * out.cov**2) if out.pf > 0.0 and math.isfinite(out.cov) else math.inf
    print("| h (m) | factor | N a level | subset pf (cov) [approx. 95% interval] | levels | FOS searches | SRF runs | "
          "wall (s) | load | crude MC for this cov: realisations | its wall at the measured rate (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print(f"| {args.spacing:g} | {args.factor:g} | {args.samples} | {out.pf:.3g} ({out.cov:.2f}) [{out.pf_low:.3g}, "
          f"{out.pf_high:.3g}] | {len(out.thresholds) + 1} | {out.n_searches} | {out.runs_made} | {wall_s:.0f} | "
          f"{before} -> {load()} | {needed:,.0f} | {needed / rate:,.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
