"""Runs per factor of safety: every shipped sweep, probabilistic study in fos mode and refinement study,
this tree against another checkout, each FOS side by side.

    python -m benchmarks.runs_per_fos --compare /tmp/base             # every such study
    python -m benchmarks.runs_per_fos --compare /tmp/base --only sweep_strength

Each study runs as a user runs it (``python -m workflows.cli``, 2 local workers, the numba cache on
disk), in this tree and in the other, alternately.  From its result file: the factors of safety it
computed, the SRF runs they rest on (summed over ``summary.nc`` of every case or level), the runs per
FOS and the wall time of the whole command; then every case's FOS in both trees and the largest
difference, against the stage's search tolerance.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("sweep_strength", "sweep_geometry", "seismic", "drawdown", "published/taylor_phi0", "probabilistic_c_phi",
           "fos_controlled", "refinement_levels")
"""The shipped studies that compute many factors of safety: sweeps, probabilistic in fos mode, refinement."""


def run(tree: Path, study: str, out: Path) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", str(ROOT / "studies" / f"{study}.toml"), "--out",
                           str(out), "--quiet"], cwd=tree, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {study} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start


def factors(out: Path) -> tuple[dict[str, float], int]:
    """(FOS by case or level folder, the runs they rest on) from the study's summaries."""
    fos, runs = {}, 0
    for summary in sorted(out.rglob("summary.nc")):
        with xr.open_dataset(summary) as ds:
            name = str(summary.parent.relative_to(out))
            fos[name] = float(ds["fos"])
            runs += int(ds.sizes["srf"])
    return fos, runs


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.runs_per_fos", description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, required=True, help="another checkout of spfem-fos")
    parser.add_argument("--only", nargs="+", choices=STUDIES, metavar="STUDY")
    args = parser.parse_args(argv)
    trees = {"this": ROOT, "other": args.compare.resolve()}
    print("| study | tree | FOS | runs | runs per FOS | wall (s) | largest FOS difference |")
    print("|---|---|---|---|---|---|---|")
    for study in args.only or STUDIES:
        found = {}
        with tempfile.TemporaryDirectory() as scratch:
            for label, tree in trees.items():
                out = Path(scratch) / label
                wall = run(tree, study, out)
                fos, runs = factors(out)
                found[label] = (fos, runs, wall)
        common = sorted(set(found["this"][0]) & set(found["other"][0]))
        differences = [abs(found["this"][0][k] - found["other"][0][k]) for k in common
                       if math.isfinite(found["this"][0][k]) and math.isfinite(found["other"][0][k])]
        largest = f"{max(differences):.4f} over {len(differences)} cases" if differences else "-"
        for label in trees:
            fos, runs, wall = found[label]
            n = sum(math.isfinite(v) for v in fos.values())
            print(f"| {study} | {label} | {n} | {runs} | {runs / max(n, 1):.2f} | {wall:.1f} | "
                  f"{largest if label == 'this' else ''} |", flush=True)
        if differences:
            print("|  |  | every case: " + ", ".join(
                f"{k.split('/')[-1]} {found['this'][0][k]:.4f} / {found['other'][0][k]:.4f}" for k in common[:12])
                + (" ..." if len(common) > 12 else "") + " | | | | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
