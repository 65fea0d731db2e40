"""The run time ``spfem-fos check`` estimates against the measured one, for every shipped
strength-reduction study.

    python -m benchmarks.check_estimate
    python -m benchmarks.check_estimate --only quickstart sweep_strength

For each study of ``STUDIES`` (single studies, sweeps, probabilistic studies in both modes,
refinement studies): the particles, the factors of safety (or realisations) it computes and the
estimate (``workflows.check``, 2 workers), then the study run as a user runs it (a fresh process,
2 local workers, the numba cache on disk), its wall time, the ratio estimate / measured, and the
SRF runs it made (summed over its ``summary.nc`` files; a verdict-mode realisation makes one run and
writes no summary).  The median and the range of the ratios end the table.  The estimate holds for
a machine as fast as the one its constants were measured on, unloaded: quote the load average.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks import bench_studies
from benchmarks.bench_studies import ROOT
from benchmarks.runs_per_fos import factors
from workflows.cases import RunOptions
from workflows.check import check_study
from workflows.study import load_study
from workflows.study_types import study_type

WORKERS = 2
STUDIES = bench_studies.STUDIES + ("sweep_strength", "sweep_geometry", "runout_residual_friction_sweep",
                                   "probabilistic_c_phi", "probabilistic_undrained", "probabilistic_undrained_cov",
                                   "refinement_levels", "fos_controlled")
"""Every shipped study that computes a factor of safety (or a verdict at one) by strength reduction."""


def run_study(name: str, out: Path) -> float:
    """The wall seconds of study ``name`` run by this tree into ``out`` as a user runs it."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", f"studies/{name}.toml", "--out", str(out),
                           "--quiet"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{name} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.check_estimate", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY", help="these studies only")
    args = parser.parse_args(argv)
    print("| study | particles | FOS computed | estimate (s) | measured (s) | estimate / measured | SRF runs made |")
    print("|---|---|---|---|---|---|---|")
    ratios = []
    for name in args.only or STUDIES:
        study = load_study(ROOT / "studies" / f"{name}.toml")
        with tempfile.TemporaryDirectory() as scratch:
            found = check_study(study, study_type(study, Path(scratch)), Path(scratch), RunOptions(workers=WORKERS))
            out = Path(scratch) / "out"
            wall_s = run_study(name, out)
            _, runs = factors(out)
        if found.estimate is None:  # (no strength reduction to estimate: a runout sweep's last stage)
            print(f"| {name} | {found.n_particles} | - | no estimate | {wall_s:.1f} | - | {runs} |", flush=True)
            continue
        estimate_s = found.estimate.study_s
        ratios.append(estimate_s / wall_s)
        print(f"| {name} | {found.n_particles} | {found.estimate.cases} | {estimate_s:.1f} | {wall_s:.1f} | "
              f"{ratios[-1]:.2f} | {runs} |", flush=True)
    print(f"\nestimate / measured: median {statistics.median(ratios):.2f}, from {min(ratios):.2f} to {max(ratios):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
