"""Speed of a probabilistic study: realisations per minute, and where the time goes.

    python -m benchmarks.bench_probabilistic                       # shipped undrained study, h = 0.5 m, 200 realisations
    python -m benchmarks.bench_probabilistic --realisations 1000   # the figures docs/benchmarks.md quotes
    python -m benchmarks.bench_probabilistic --spacing 1 --realisations 500 --keep-fields all

Runs ``studies/probabilistic_undrained.toml`` (a cu field, verdict mode at F = 1) from an empty
folder on ``--workers`` local workers and prints the wall time, realisations per minute, the time
projected for 1,000, and the share of the workers' time outside the runs' stepping loops (scene
build, field generation, mesh, task and file overhead, the cluster's start, the gravity state and
the final file and figures: 1 - sum of the runs' loop time / (workers x wall)), with the share of
remeshing inside the loops; then the disk use of the output folder, per 1,000 realisations, for
``--keep-fields`` (``[probabilistic] keep_fields``, default the study's: failed).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from verification.undrained_variants import field_text, shipped_text
from workflows.cases import RunOptions
from workflows.study import parse_study
from workflows.study_types import run_study


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=0.5)
    parser.add_argument("--realisations", type=int, default=200)
    parser.add_argument("--cov", type=float, default=0.5)
    parser.add_argument("--theta", type=float, default=10.0, help="scale of fluctuation (m)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--keep-fields", choices=("failed", "all", "none"), default=None)
    args = parser.parse_args(argv)
    text = field_text(shipped_text(args.spacing), args.cov, args.theta, args.realisations)
    if args.keep_fields is not None:
        text = text.replace("[probabilistic]\n", f'[probabilistic]\nkeep_fields = "{args.keep_fields}"\n', 1)
    study = parse_study(text)
    with tempfile.TemporaryDirectory() as scratch:
        outcome = run_study(study, Path(scratch) / "out", RunOptions(workers=args.workers))
        disk_bytes = sum(path.stat().st_size for path in (Path(scratch) / "out").rglob("*") if path.is_file())
    t = outcome.timings_s
    n = outcome.n_realisations
    outside = 1.0 - t["run_loops"] / (args.workers * t["total"])
    print(f"h = {args.spacing:g} m, {n} realisations, {args.workers} workers: wall {t['total']:.1f} s, "
          f"{60.0 * n / t['total']:.0f} realisations/min, 1,000 in {1000.0 * t['total'] / n / 60.0:.1f} min; "
          f"pf {outcome.pf:.3f} [{outcome.pf_low:.3f}, {outcome.pf_high:.3f}]")
    print(f"outside the runs' stepping loops: {outside:.1%} of the workers' time; remeshing "
          f"{t['remesh'] / t['run_loops']:.1%} of the loops")
    print(f"disk: {disk_bytes / 1e6:.1f} MB ({outcome.n_failed} failed realisations), "
          f"{disk_bytes / n * 1000 / 1e9:.2f} GB per 1,000 realisations (keep_fields = "
          f"{study.probabilistic.keep_fields})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
