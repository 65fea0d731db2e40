"""The run time ``spfem-fos check`` estimates against the measured one, for every shipped
strength-reduction study.

    python -m benchmarks.check_estimate
    python -m benchmarks.check_estimate --only quickstart sweep_strength
    python -m benchmarks.check_estimate --compare /tmp/base     # also another checkout's estimate

For each study of ``STUDIES`` (single studies, sweeps, probabilistic studies in both modes,
refinement studies): the particles, the factors of safety (or realisations) it computes and the
estimate (``workflows.check``, 2 workers), then the study run as a user runs it (a fresh process,
2 local workers, the numba cache on disk), its wall time, the ratio estimate / measured, and the
SRF runs it made (summed over its ``summary.nc`` files; a verdict-mode realisation makes one run and
writes no summary).  The median and the range of the ratios end the table.  The estimate holds for
a machine as fast as the one its constants were measured on, unloaded: quote the load average (printed
before and after each study).  With ``--compare``, the other checkout's estimate of the same study (its
``check_study`` in a process of its own) over the same measured time.
"""

from __future__ import annotations

import argparse
import os
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
                                   "refinement_levels", "fos_controlled", "rain", "drawdown_time", "rain_threshold")
"""Every shipped study that computes a factor of safety (or a verdict at one) by strength reduction."""


def run_study(name: str, out: Path) -> float:
    """The wall seconds of study ``name`` run by this tree into ``out`` as a user runs it."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", f"studies/{name}.toml", "--out", str(out),
                           "--quiet"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{name} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start


OTHER_ESTIMATE = """
import sys, tempfile
from pathlib import Path
from workflows.cases import RunOptions
from workflows.check import check_study
from workflows.study import load_study
from workflows.study_types import study_type
study = load_study(Path(sys.argv[1]))
with tempfile.TemporaryDirectory() as scratch:
    found = check_study(study, study_type(study, Path(scratch)), Path(scratch), RunOptions(workers=int(sys.argv[2])))
print(found.estimate.study_s if found.estimate is not None else "nan")
"""


def other_estimate(tree: Path, name: str) -> float:
    """The study time ``check`` of the checkout ``tree`` estimates for study ``name``."""
    done = subprocess.run([sys.executable, "-c", OTHER_ESTIMATE, str(ROOT / "studies" / f"{name}.toml"), str(WORKERS)],
                          cwd=tree, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(tree)})
    if done.returncode != 0:
        raise SystemExit(f"{tree}: check of {name} failed:\n{done.stderr[-2000:]}")
    return float(done.stdout.split()[-1])


def load_average() -> str:
    """The 1-minute load average, as ``uptime`` gives it."""
    return f"{os.getloadavg()[0]:.2f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.check_estimate", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY", help="these studies only")
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos: its estimate too")
    args = parser.parse_args(argv)
    other = "" if args.compare is None else " other's estimate (s) | other's estimate / measured |"
    print(f"| study | particles | FOS computed | estimate (s) | measured (s) | estimate / measured |{other} SRF runs made "
          "| load before, after |")
    print("|---|---|---|---|---|---|---|---|" + "---|---|" * (args.compare is not None))
    ratios, other_ratios = [], []
    for name in args.only or STUDIES:
        study = load_study(ROOT / "studies" / f"{name}.toml")
        with tempfile.TemporaryDirectory() as scratch:
            found = check_study(study, study_type(study, Path(scratch)), Path(scratch), RunOptions(workers=WORKERS))
            out = Path(scratch) / "out"
            before = load_average()
            wall_s = run_study(name, out)
            load = f"{before}, {load_average()}"
            _, runs, _ = factors(out)
        if found.estimate is None:  # (no strength reduction to estimate: a runout sweep's last stage)
            print(f"| {name} | {found.n_particles} | - | no estimate | {wall_s:.1f} | - |{' - | - |' * bool(other)} "
                  f"{runs} | {load} |", flush=True)
            continue
        estimate_s = found.estimate.study_s
        ratios.append(estimate_s / wall_s)
        compared = ""
        if args.compare is not None:
            other_s = other_estimate(args.compare, name)
            other_ratios.append(other_s / wall_s)
            compared = f" {other_s:.1f} | {other_ratios[-1]:.2f} |"
        print(f"| {name} | {found.n_particles} | {found.estimate.cases} | {estimate_s:.1f} | {wall_s:.1f} | "
              f"{ratios[-1]:.2f} |{compared} {runs} | {load} |", flush=True)
    for label, values in (("estimate", ratios), ("other's estimate", other_ratios)):
        if values:
            inside = sum(0.7 <= v <= 1.3 for v in values)
            print(f"\n{label} / measured: median {statistics.median(values):.2f}, from {min(values):.2f} to "
                  f"{max(values):.2f}; {inside} of {len(values)} within [0.7, 1.3]")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
