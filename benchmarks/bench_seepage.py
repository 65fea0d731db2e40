"""The steady-seepage solve against the FOS study it feeds.

    python -m benchmarks.bench_seepage          # the shipped seepage studies

For each study: the particles, the flow's iterations and solve time (the cloud, the first mesh, the
assembly and the Picard iterations, ``workflows.seepage.flow``), and the wall time of the whole FOS
study from an empty folder on 2 local workers (gravity, every SRF run, the files and figures); the
study's process solves the flow once and the workers take it from there.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("seepage_dam", "seepage_perched")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    from workflows.cases import RunOptions
    from workflows.seepage.flow import study_flow
    from workflows.study import load_study
    from workflows.study_types import run_study

    print("| study | particles | iterations | solve (s) | FOS | FOS study wall (s) | solve / study |")
    print("|---|---|---|---|---|---|---|")
    for name in STUDIES:
        study = load_study(ROOT / "studies" / f"{name}.toml")
        start = time.perf_counter()
        flow = study_flow(study)
        solve_s = time.perf_counter() - start
        with tempfile.TemporaryDirectory() as scratch:
            start = time.perf_counter()
            outcome = run_study(study, Path(scratch) / "out", RunOptions(workers=args.workers))
            study_s = time.perf_counter() - start
        print(f"| {name} | {flow.node_xy_m.shape[0]} | {flow.solution.iterations} | {solve_s:.2f} | {outcome.fos:.4f} | "
              f"{study_s:.1f} | {solve_s / study_s:.1%} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
