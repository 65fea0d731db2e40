"""Every shipped strength-reduction study: its FOS and wall time, against another checkout.

    python -m benchmarks.bench_studies                          # this tree
    python -m benchmarks.bench_studies --compare ../other-tree  # and another checkout, alternated
    python -m benchmarks.bench_studies --only quickstart reference_slope
    python -m benchmarks.bench_studies --compare ../other-tree --repeats 3   # medians of 3 pairs

Each study runs as a user runs it, ``python -m workflows.cli STUDY --out <fresh folder> --quiet``
(2 local workers, the numba cache on disk: run each tree once beforehand to fill it), in a fresh
process; the wall time is the whole command's.  The last line it prints is the result: the FOS
line of a single study, the last row of a sweep's table.  With ``--compare`` the two trees
alternate run by run, each going first in every other pair (so that neither is always the
first), the ratio is the median of the pairs' ratios, and their FOS and bracket must match (the
line up to its first ``]``: a sweep row's run count is left out, as runs above the first failure
finish or are stopped depending on timing): a speed change that moves an FOS shows here.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("quickstart", "reference_slope", "drawdown", "seismic", "strip_load", "published/acads_1a",
           "published/acads_1c", "published/griffiths_lane_ex4", "published/taylor_phi0",
           "published/verruijt_slope", "seepage_dam", "seepage_perched")
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
    parser.add_argument("--repeats", type=int, default=1, help="runs of each study in each tree (default 1)")
    args = parser.parse_args(argv)
    trees = {"this": ROOT} | ({"other": args.compare.resolve()} if args.compare else {})
    differ = 0
    pair = 0
    for study in args.only or STUDIES:
        walls = {label: [] for label in trees}
        lines = {label: set() for label in trees}
        for _ in range(args.repeats):
            order = list(trees) if pair % 2 == 0 else list(trees)[::-1]
            pair += 1
            for label in order:
                wall, line = run_study(trees[label], study)
                walls[label].append(wall)
                lines[label].add(line)
        shown = " / ".join(f"{label} {statistics.median(w):.1f} s" for label, w in walls.items())
        ratio = (f", this/other {statistics.median(a / b for a, b in zip(walls['this'], walls['other'])):.2f}"
                 if len(trees) == 2 else "")
        print(f"{study}: {shown}{ratio}\n    {sorted(lines['this'])[0]}", flush=True)
        results = {" ".join(fos_and_bracket(line).split()) for found in lines.values() for line in found}
        if len(results) > 1:
            differ += 1
            print(f"    other: {sorted(lines.get('other', {''}))[0]}  <- a different FOS (or one that moved "
                  "between runs)")
    if len(trees) == 2:
        print("every result the same in both trees" if not differ else f"{differ} studies differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
