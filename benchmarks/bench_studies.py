"""Every shipped strength-reduction study: its FOS and wall time, against another checkout.

    python -m benchmarks.bench_studies                          # this tree
    python -m benchmarks.bench_studies --compare ../other-tree  # and another checkout, alternated
    python -m benchmarks.bench_studies --only quickstart reference_slope

Each study runs as a user runs it, ``python -m workflows.cli STUDY --out <fresh folder> --quiet``
(2 local workers, the numba cache on disk: run each tree once beforehand to fill it), in a fresh
process; the wall time is the whole command's.  The last line it prints is the result: the FOS
line of a single study, the last row of a sweep's table.  With ``--compare`` the two trees
alternate study by study, and their FOS and bracket must match (the line up to its first
``]``: a sweep row's run count is left out, as runs above the first failure finish or are
stopped depending on timing): a speed change that moves an FOS shows here.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("quickstart", "reference_slope", "drawdown", "seismic", "strip_load", "published/acads_1a",
           "published/acads_1c", "published/griffiths_lane_ex4", "published/taylor_phi0",
           "published/verruijt_slope")
"""Every study of ``studies/`` whose last stage is a strength reduction (or a sweep of one)."""


def run_study(tree: Path, study: str) -> tuple[float, str]:
    """(wall seconds, the last line printed) of ``study`` run by ``tree``."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "workflows.cli", f"studies/{study}.toml", "--out", out,
                               "--quiet"], cwd=tree, capture_output=True, text=True)
        wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {study} failed:\n{done.stderr[-2000:]}")
    return wall, done.stdout.strip().splitlines()[-1]


def fos_and_bracket(line: str) -> str:
    """The result line up to its first ``]``: the FOS and its bracket (module doc)."""
    return line[: line.index("]") + 1] if "]" in line else line


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_studies", description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos, run alternately")
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY", help="these studies only")
    args = parser.parse_args(argv)
    trees = {"this": ROOT} | ({"other": args.compare.resolve()} if args.compare else {})
    differ = 0
    for study in args.only or STUDIES:
        results = {label: run_study(tree, study) for label, tree in trees.items()}
        walls = " / ".join(f"{label} {wall:.1f} s" for label, (wall, _) in results.items())
        lines = {" ".join(fos_and_bracket(line).split()) for _, line in results.values()}
        ratio = f", this/other {results['this'][0] / results['other'][0]:.2f}" if len(trees) == 2 else ""
        print(f"{study}: {walls}{ratio}\n    {results['this'][1]}", flush=True)
        if len(lines) > 1:
            differ += 1
            print(f"    other: {results['other'][1]}  <- a different FOS")
    if len(trees) == 2:
        print("every result the same in both trees" if not differ else f"{differ} studies differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
