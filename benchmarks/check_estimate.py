"""The run time ``spfem-fos check`` estimates against the measured one, for every shipped
strength-reduction study.

    python -m benchmarks.check_estimate
    python -m benchmarks.check_estimate --only quickstart reference_slope

For each study of ``benchmarks.bench_studies.STUDIES``: the particles, the factors of safety it
computes and the estimate (``workflows.check``, 2 workers), then the study run as a user runs it
(``bench_studies.run_study``: a fresh process, 2 local workers, the numba cache on disk), its wall
time, the ratio estimate / measured, and the SRF runs it made.  The median and the range of the
ratios end the table.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from benchmarks.bench_studies import ROOT, STUDIES, run_study
from workflows.check import check_study
from workflows.study import load_study

WORKERS = 2


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.check_estimate", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY", help="these studies only")
    args = parser.parse_args(argv)
    print("| study | particles | FOS computed | estimate (s) | measured (s) | estimate / measured |")
    print("|---|---|---|---|---|---|")
    ratios = []
    for name in args.only or STUDIES:
        study = load_study(ROOT / "studies" / f"{name}.toml")
        with tempfile.TemporaryDirectory() as scratch:
            found = check_study(study, Path(scratch), WORKERS)
        wall_s, _ = run_study(ROOT, name)
        estimate_s = found.estimate.study_s
        ratios.append(estimate_s / wall_s)
        print(f"| {name} | {found.n_particles} | {found.estimate.cases} | {estimate_s:.1f} | {wall_s:.1f} | "
              f"{ratios[-1]:.2f} |", flush=True)
    print(f"\nestimate / measured: median {statistics.median(ratios):.2f}, from {min(ratios):.2f} to {max(ratios):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
