"""The limit-equilibrium search's time per call: the quick search that places every FOS search's window
(``fos.prediction``: once per realisation of a probabilistic study whose variables change the soil, once per
case of a sweep) and the full one of ``spfem-fos check``.

    python -m benchmarks.critical_circle_time                       # this tree
    python -m benchmarks.critical_circle_time --compare ../other    # and another checkout after it

For each shipped study with a strength-reduction stage: the median of ``--repeats`` calls of
``critical_circle(study, quick=True)`` and of the full search, after one call that compiles or loads the
compiled code; with ``--compare`` the same in the other checkout's code (its own process, after this
one's), its least F beside this tree's, and the ratio other / this of the medians.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MEASURE = r"""
import json, pathlib, statistics, sys, time
from workflows.study import parse_study
from workflows.fos.critical_circle import critical_circle
rows = {}
for path in sorted(pathlib.Path(sys.argv[1]).rglob("*.toml")):
    study = parse_study(path.read_text())
    if study.strength_reduction is None:
        continue
    row = {}
    for name, quick in (("quick", True), ("full", False)):
        circle = critical_circle(study, quick=quick)
        seconds = []
        for _ in range(int(sys.argv[2])):
            start = time.perf_counter()
            critical_circle(study, quick=quick)
            seconds.append(time.perf_counter() - start)
        row[name] = (statistics.median(seconds), None if circle is None else circle.fos)
    rows[str(path.relative_to(sys.argv[1]))] = row
print(json.dumps(rows))
"""


def measure(tree: Path, studies: Path, repeats: int) -> dict:
    """{study: {"quick"/"full": (median seconds, F)}} measured by ``tree``'s code in its own process."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    result = subprocess.run([sys.executable, "-c", MEASURE, str(studies), str(repeats)], cwd=tree, env=env,
                            capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    studies = ROOT / "studies"
    this = measure(ROOT, studies, args.repeats)
    other = measure(args.compare.resolve(), studies, args.repeats) if args.compare else None
    print(f"load average {os.getloadavg()[0]:.1f}; medians of {args.repeats} calls (ms)")
    header = "| study | quick | full |" + (" other quick | other full | ratio quick | ratio full | F (this / other) |"
                                            if other else " F |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for name, row in this.items():
        cells = [f"{1e3 * row['quick'][0]:.1f}", f"{1e3 * row['full'][0]:.1f}"]
        if other and name in other:
            o = other[name]
            cells += [f"{1e3 * o['quick'][0]:.1f}", f"{1e3 * o['full'][0]:.1f}",
                      f"{o['quick'][0] / row['quick'][0]:.1f}", f"{o['full'][0] / row['full'][0]:.1f}",
                      f"{row['full'][1]:.6g} / {o['full'][1]:.6g}"]
        else:
            cells.append(f"{row['full'][1]:.6g}")
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
