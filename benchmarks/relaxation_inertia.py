"""Run time against error of the SRF runs' relaxation: true or equalised inertia, by local damping.

    python -m benchmarks.relaxation_inertia                      # every shipped FOS study
    python -m benchmarks.relaxation_inertia --only strip_load published/acads_1c
    python -m benchmarks.relaxation_inertia --inertia equalised --dampings 0.9 0.97

A strength-reduction run is a damped relaxation from the gravity state, and near the FOS its end
state depends a little on the path the damped dynamics take (plasticity and the moving geometry
remember it).  Heavier damping makes the path more nearly quasi-static, at the cost of steps.
For each study (``benchmarks.bench_studies.STUDIES``) this prints the FOS and the command's wall
time with ``solver.uniform_relaxation_step`` true and false (``timestep.equalised_inertia``), each
at the study's damping and at the ``--dampings`` given (default: the study's and 0.93, near the
quasi-static limit: the reference for the path error).  Each study runs as a user runs it (2 local workers, the numba cache on disk), in
a fresh process; one run each.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.bench_studies import STUDIES, fos_and_bracket

ROOT = Path(__file__).resolve().parents[1]


def variant(text: str, uniform: bool, damping: float | None) -> str:
    """The study text with ``solver.uniform_relaxation_step = uniform`` and (when given) its
    strength-reduction stage's ``damping``."""
    line = f"uniform_relaxation_step = {'true' if uniform else 'false'}\n"
    if re.search(r"^\[solver\]\n", text, flags=re.M):
        text = re.sub(r"^\[solver\]\n", "[solver]\n" + line, text, count=1, flags=re.M)
    else:
        text = re.sub(r"^\[\[stages\]\]", "[solver]\n" + line + "\n[[stages]]", text, count=1, flags=re.M)
    if damping is not None:
        text = re.sub(r'^(kind = "strength_reduction"\n)(damping = .*\n)?', rf"\g<1>damping = {damping}\n", text,
                      count=1, flags=re.M)
    return text


def run(text: str) -> tuple[float, str]:
    """(wall seconds, FOS and bracket) of the study ``text``."""
    with tempfile.TemporaryDirectory() as folder:
        study = Path(folder) / "study.toml"
        study.write_text(text)
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", f"{folder}/out", "--quiet"],
                              cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"failed:\n{done.stderr[-2000:]}")
    return wall, fos_and_bracket(done.stdout.strip().splitlines()[-1]).strip()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.relaxation_inertia", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY", help="these studies only")
    parser.add_argument("--dampings", nargs="+", default=["default", "0.93"], metavar="DAMPING",
                        help="the SRF runs' local damping factors to run, `default` the study's (default: default "
                        "0.93, the second near the quasi-static limit)")
    parser.add_argument("--inertia", nargs="+", choices=("equalised", "true"), default=["equalised", "true"])
    args = parser.parse_args(argv)
    dampings = [None if d == "default" else float(d) for d in args.dampings]
    print(f"{'study':30s} {'inertia':10s} {'damping':>8s} {'wall (s)':>9s}  FOS, bracket")
    for study in args.only or STUDIES:
        text = (ROOT / "studies" / f"{study}.toml").read_text()
        for uniform in [inertia == "equalised" for inertia in args.inertia]:
            for damping in dampings:
                wall, result = run(variant(text, uniform, damping))
                print(f"{study:30s} {'equalised' if uniform else 'true':10s} {damping or 'default':>8} {wall:9.1f}  "
                      f"{' '.join(result.split())}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
