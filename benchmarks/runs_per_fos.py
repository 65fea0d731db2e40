"""Runs per factor of safety: every shipped sweep, probabilistic study in fos mode and refinement study,
this tree against another checkout, each FOS side by side.

    python -m benchmarks.runs_per_fos --compare /tmp/base             # every such study
    python -m benchmarks.runs_per_fos --compare /tmp/base --only sweep_strength
    python -m benchmarks.runs_per_fos --compare /tmp/base --only probabilistic_undrained:fos

Each study runs as a user runs it (``python -m workflows.cli``, 2 local workers, the numba cache on
disk), in this tree and in the other, alternately.  From its result file: the factors of safety it
computed, the SRF runs they rest on (summed over ``summary.nc`` of every case or level), the runs per
FOS and the wall time of the whole command; then every case's FOS in both trees and the largest
difference, against the stage's search tolerance.  A probabilistic study also gets its FOS statistics
in both trees, each with its 95% interval: the mean and standard deviation of the FOS found, and pf at
1.0 and 1.2 (a realisation whose every run failed has its FOS below srf_min).

``probabilistic_undrained:fos`` (not in the default set: about 8 minutes a tree at 2 workers) is
``studies/probabilistic_undrained.toml`` with ``compute = "fos"`` (written into the scratch folder):
200 FOS searches on a random field; its runs are also given per realisation (those whose every run
failed make one or a few) and per FOS found counting only the searches that found one.  The wall time is given with the load average before and after the command.

"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ("sweep_strength", "sweep_geometry", "seismic", "drawdown", "published/taylor_phi0", "probabilistic_c_phi",
           "fos_controlled", "refinement_levels")
"""The shipped studies that compute many factors of safety: sweeps, probabilistic in fos mode, refinement."""
VARIANTS = {"probabilistic_undrained:fos": ("probabilistic_undrained", 'compute = "verdict"', 'compute = "fos"')}
"""A shipped study run another way (module doc): its name, a line of it and what replaces that line."""


def study_file(study: str, scratch: Path) -> Path:
    """The study file of ``study``: a shipped one, or a variant written into ``scratch``."""
    if study not in VARIANTS:
        return ROOT / "studies" / f"{study}.toml"
    name, line, replacement = VARIANTS[study]
    text = (ROOT / "studies" / f"{name}.toml").read_text()
    if line not in text:
        raise SystemExit(f"{name}.toml has no line {line!r} to make {study} from")
    path = scratch / f"{name}_variant.toml"
    path.write_text(text.replace(line, replacement))
    return path


def run(tree: Path, study_path: Path, out: Path) -> tuple[float, str]:
    """The command's wall time (s) and the 1-minute load average before and after it."""
    before = os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study_path), "--out",
                           str(out), "--quiet"], cwd=tree, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {study_path.name} failed:\n{done.stderr[-2000:]}")
    return time.perf_counter() - start, f"load {before:.1f}, {os.getloadavg()[0]:.1f}"


def factors(out: Path) -> tuple[dict[str, float], int, int]:
    """(FOS by case or level folder, the runs they rest on, the runs of the searches that found a FOS) from
    the study's summaries."""
    fos, runs, runs_found = {}, 0, 0
    for summary in sorted(out.rglob("summary.nc")):
        with xr.open_dataset(summary) as ds:
            name = str(summary.parent.relative_to(out))
            fos[name] = float(ds["fos"])
            runs += int(ds.sizes["srf"])
            runs_found += int(ds.sizes["srf"]) if math.isfinite(fos[name]) else 0
    return fos, runs, runs_found


def fos_statistics(out: Path) -> str:
    """A probabilistic study's FOS statistics with their 95% intervals (module doc), or "" for another study."""
    from scipy import stats

    from workflows.probabilistic.reliability import failure_probability

    result = out / "probabilistic.nc"
    if not result.exists():
        return ""
    with xr.open_dataset(result) as ds:
        fos, below = ds["fos"].values.astype(float), ds["status"].values.astype(str) == "below_srf_min"
    found = fos[np.isfinite(fos)]
    n, mean, std = found.size, float(found.mean()), float(found.std(ddof=1))
    t = float(stats.t.ppf(0.975, n - 1))
    chi_low, chi_high = stats.chi2.ppf([0.975, 0.025], n - 1)
    parts = [f"{n} FOS found, mean {mean:.4f} [{mean - t * std / math.sqrt(n):.4f}, {mean + t * std / math.sqrt(n):.4f}]",
             f"std {std:.4f} [{std * math.sqrt((n - 1) / chi_low):.4f}, {std * math.sqrt((n - 1) / chi_high):.4f}]"]
    for factor in (1.0, 1.2):
        pf, low, high = failure_probability(int(np.sum(below | (fos < factor))), fos.size)
        parts.append(f"pf({factor:g}) {pf:.3f} [{low:.3f}, {high:.3f}]")
    return ", ".join(parts)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.runs_per_fos", description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, required=True, help="another checkout of spfem-fos")
    parser.add_argument("--only", nargs="+", choices=STUDIES + tuple(VARIANTS), metavar="STUDY")
    args = parser.parse_args(argv)
    trees = {"this": ROOT, "other": args.compare.resolve()}
    print("| study | tree | FOS | runs | runs per FOS | wall (s) | largest FOS difference |")
    print("|---|---|---|---|---|---|---|")
    for study in args.only or STUDIES:
        found = {}
        statistics = {}
        with tempfile.TemporaryDirectory() as scratch:
            path = study_file(study, Path(scratch))
            for label, tree in trees.items():
                out = Path(scratch) / label
                wall, load = run(tree, path, out)
                fos, runs, runs_found = factors(out)
                found[label] = (fos, runs, runs_found, f"{wall:.1f} ({load})")
                statistics[label] = fos_statistics(out)
        common = sorted(set(found["this"][0]) & set(found["other"][0]))
        differences = [abs(found["this"][0][k] - found["other"][0][k]) for k in common
                       if math.isfinite(found["this"][0][k]) and math.isfinite(found["other"][0][k])]
        largest = f"{max(differences):.4f} over {len(differences)} cases" if differences else "-"
        for label in trees:
            fos, runs, runs_found, wall = found[label]
            n = sum(math.isfinite(v) for v in fos.values())
            per = f"{runs / max(n, 1):.2f}" + (f" ({runs / len(fos):.2f} per realisation, {runs_found / max(n, 1):.2f} "
                                               "in the searches that found one)" if statistics[label] else "")
            print(f"| {study} | {label} | {n} | {runs} | {per} | {wall} | "
                  f"{largest if label == 'this' else ''} |", flush=True)
        if differences:
            print("|  |  | every case: " + ", ".join(
                f"{k.split('/')[-1]} {found['this'][0][k]:.4f} / {found['other'][0][k]:.4f}" for k in common[:12])
                + (" ..." if len(common) > 12 else "") + " | | | | |")
        for label in trees:
            if statistics[label]:
                print(f"|  | {label} | {statistics[label]} | | | | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
