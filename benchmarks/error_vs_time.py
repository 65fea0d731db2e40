"""Run time against error: the benchmark behind the README's Pareto fronts.

    python -m benchmarks.error_vs_time beam  [--out bench_results/beam]  [--quick]
    python -m benchmarks.error_vs_time slope [--out bench_results/slope] [--quick]

**beam** (``studies/cantilever_beam.toml``, 4 s): particle spacing 0.05, 0.04, 0.02, 0.01 m
times CFL factor 0.25, 0.5, 0.9.  Error: the larger of the relative errors of the first
period and of the mean tip deflection against the converged value, a Richardson
extrapolation h -> 0 of the cfl 0.5 runs at the two finest spacings with the order measured
on the three finest (recorded in the table's attributes).

**slope** (``studies/quickstart.toml`` with changes): FOS at spacing 1.0, 0.6, 0.4, 0.3,
0.2 m with the default settings (quasi-static protocol); at 0.4 m also the longest SRF run
2.5 and 10 s instead of 5 s, stabilisation beta 0 and 0.3, a remesh threshold of 10 deg
instead of 20, and a convergence tolerance of 1e-4 instead of 1e-5 (also at 1 m).  Error:
|FOS - 1.368| / 1.368 (limit equilibrium 1.366-1.369, least upper bound 1.368).  Wall time of
the whole study on 2 workers, warm cache, gravity computed afresh.

Each writes ``<case>.nc`` (one row per case: settings, result, error, wall time, on the
Pareto front or not) and ``<case>_pareto.png`` (error against wall time, the front joined)
to ``--out``, and prints the table.  ``--quick`` runs a subset (for trying it out).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from spfem_core.simulation import Simulation
from verification.oscillation import period_and_mean
from workflows.cases import RunOptions
from workflows.output.writing import write_dataset
from workflows.scene import build_scene, monitor_particles, solver_settings
from workflows.study import parse_study
from workflows.study_types import run_study

ROOT = Path(__file__).resolve().parents[1]
FOS_REFERENCE = 1.368


@dataclass
class Case:
    """One benchmark case: its settings, what it measured and how long it took."""

    label: str
    settings: dict
    results: dict = field(default_factory=dict)
    error: float = math.nan
    wall_s: float = math.nan


def pareto_front(wall_s: np.ndarray, error: np.ndarray) -> np.ndarray:
    """True for the cases no other case beats in both wall time and error."""
    on_front = np.zeros(wall_s.size, dtype=bool)
    for i in range(wall_s.size):
        dominated = (wall_s <= wall_s[i]) & (error <= error[i]) & ((wall_s < wall_s[i]) | (error < error[i]))
        on_front[i] = np.isfinite(error[i]) and not dominated.any()
    return on_front


# ------------------------------------------------------------------------------ beam


def _beam_case(spacing_m: float, cfl: float) -> Case:

    text = (ROOT / "studies" / "cantilever_beam.toml").read_text()
    text = text.replace("spacing_m = 0.02", f"spacing_m = {spacing_m}").replace("cfl = 0.5", f"cfl = {cfl}")
    study = parse_study(text)
    start = time.perf_counter()
    scene = build_scene(study)
    sim = Simulation(scene, solver_settings(study))
    series = sim.run(4.0, record_interval_s=0.001, monitor_nodes=monitor_particles(study, scene))
    wall = time.perf_counter() - start
    period, mean_uy, _ = period_and_mean(series.time_s, series.monitor_displacement_m[:, 0, 1])
    mean = -mean_uy  # deflection, positive downwards
    return Case(f"h {spacing_m} cfl {cfl}", {"spacing_m": spacing_m, "cfl": cfl},
                {"period_s": period, "mean_deflection_m": mean, "n_particles": sim.n_particles,
                 "n_steps": series.n_steps}, wall_s=wall)


def _richardson(h, value):
    """(extrapolated value, order) from the three finest (h, value) pairs; order 1 if not monotone."""
    (h1, v1), (h2, v2), (h3, v3) = sorted(zip(h, value))[:3]  # finest first
    order = 1.0
    if (v3 - v2) * (v2 - v1) > 0 and abs(v2 - v1) > 0:
        order = math.log(abs(v3 - v2) / abs(v2 - v1)) / math.log(h3 / h2) if h3 / h2 == h2 / h1 else order
        order = min(max(order, 0.5), 3.0)
    ratio = (h2 / h1) ** order
    return v1 + (v1 - v2) / (ratio - 1.0), order


def bench_beam(quick: bool) -> tuple[list[Case], dict]:
    spacings = [0.05, 0.04, 0.02] if quick else [0.05, 0.04, 0.02, 0.01]
    cfls = [0.5, 0.9] if quick else [0.25, 0.5, 0.9]
    cases = []
    for spacing in spacings:
        for cfl in cfls:
            case = _beam_case(spacing, cfl)
            print(f"  {case.label}: period {case.results['period_s']:.4f} s, mean {case.results['mean_deflection_m']:.4f} m, "
                  f"{case.wall_s:.1f} s", flush=True)
            cases.append(case)
    at_half = [c for c in cases if c.settings["cfl"] == 0.5]
    h = [c.settings["spacing_m"] for c in at_half]
    reference = {}
    for key in ("period_s", "mean_deflection_m"):
        value, order = _richardson(h, [c.results[key] for c in at_half])
        reference[f"converged_{key}"] = value
        reference[f"order_{key}"] = order
    for case in cases:
        case.error = max(abs(case.results[k] / reference[f"converged_{k}"] - 1.0) for k in ("period_s", "mean_deflection_m"))
    return cases, reference


# ------------------------------------------------------------------------------ slope


def _slope_case(label: str, settings: dict, scratch: Path) -> Case:

    text = (ROOT / "studies" / "quickstart.toml").read_text()
    text = text.replace("spacing_m = 1.0", f"spacing_m = {settings['spacing_m']}")
    text = text.replace("duration_s = 5.0", f"duration_s = {settings['duration_s']}")
    text = text.replace("stabilisation_beta = 0.1", f"stabilisation_beta = {settings['beta']}")
    text = text.replace("[solver]", f"[solver]\nremesh_min_angle_deg = {settings['remesh_min_angle_deg']}")
    text = text.replace("fos_tolerance = 0.01", f"fos_tolerance = 0.01\ntolerance = {settings['tolerance']}")
    study = parse_study(text)
    start = time.perf_counter()
    outcome = run_study(study, scratch / label.replace(" ", "_"), RunOptions(workers=2))
    wall = time.perf_counter() - start
    return Case(label, settings, {"fos": outcome.fos, "fos_low": outcome.fos_low, "fos_high": outcome.fos_high,
                                  "n_particles": outcome.n_particles, "n_runs": len(outcome.runs)},
                error=abs(outcome.fos / FOS_REFERENCE - 1.0), wall_s=wall)


def bench_slope(quick: bool) -> tuple[list[Case], dict]:
    base = {"spacing_m": 1.0, "duration_s": 5.0, "beta": 0.1, "remesh_min_angle_deg": 20.0, "tolerance": 1e-5}
    plan = [(f"h {h}", dict(base, spacing_m=h)) for h in ([1.0, 0.6, 0.4] if quick else [1.0, 0.6, 0.4, 0.3, 0.2])]
    variant_h = 0.6 if quick else 0.4
    plan += [
        (f"h {variant_h} duration {d}", dict(base, spacing_m=variant_h, duration_s=d)) for d in (2.5, 10.0)
    ] + [
        (f"h {variant_h} beta {b}", dict(base, spacing_m=variant_h, beta=b)) for b in (0.0, 0.3)
    ] + [(f"h {variant_h} remesh 10deg", dict(base, spacing_m=variant_h, remesh_min_angle_deg=10.0))
    ] + [(f"h {h} tolerance 1e-4", dict(base, spacing_m=h, tolerance=1e-4)) for h in (1.0, variant_h)]
    cases = []
    with tempfile.TemporaryDirectory() as scratch:
        for label, settings in plan:
            case = _slope_case(label, settings, Path(scratch))
            print(f"  {label}: FOS {case.results['fos']:.4f}, error {100 * case.error:.2f}%, {case.wall_s:.1f} s", flush=True)
            cases.append(case)
    return cases, {"reference_fos": FOS_REFERENCE}


# ------------------------------------------------------------------------------ output


def table(cases: list[Case], attrs: dict) -> xr.Dataset:
    wall = np.array([c.wall_s for c in cases])
    error = np.array([c.error for c in cases])
    ds = xr.Dataset(coords={"case": ("case", np.array([c.label for c in cases], dtype=object))})
    for key in cases[0].settings:
        ds[key] = ("case", np.array([c.settings[key] for c in cases]))
    for key in cases[0].results:
        ds[key] = ("case", np.array([c.results[key] for c in cases]))
    ds["wall_time"] = ("case", wall, {"units": "s", "long_name": "wall time of the case"})
    ds["error"] = ("case", error, {"units": "1", "long_name": "relative error against the reference"})
    ds["pareto"] = ("case", pareto_front(wall, error).astype(np.int8),
                    {"long_name": "1 when no other case is both faster and more accurate"})
    ds.attrs.update({k: v for k, v in attrs.items()})
    return ds


def plot(ds: xr.Dataset, path: Path, title: str) -> None:
    matplotlib.use("Agg")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    wall, error = ds["wall_time"].values, np.maximum(ds["error"].values, 1e-5)
    front = ds["pareto"].values.astype(bool)
    ax.plot(wall, error, "o", color="0.6")
    order = np.argsort(wall[front])
    ax.plot(wall[front][order], error[front][order], "o-", color="tab:red", label="Pareto front")
    for label, x, y in zip(ds["case"].values, wall, error):
        ax.annotate(str(label), (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set(xscale="log", yscale="log", xlabel="wall time (s)", ylabel="relative error", title=title)
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.error_vs_time", description=__doc__.splitlines()[0])
    parser.add_argument("which", choices=("beam", "slope"))
    parser.add_argument("--out", type=Path, default=None, help="output folder (default bench_results/<which>)")
    parser.add_argument("--quick", action="store_true", help="a subset of the cases")
    args = parser.parse_args(argv)
    out = args.out or Path("bench_results") / args.which
    out.mkdir(parents=True, exist_ok=True)
    print(f"{args.which}:", flush=True)
    cases, attrs = (bench_beam if args.which == "beam" else bench_slope)(args.quick)
    ds = table(cases, attrs)

    write_dataset(ds, out / f"{args.which}.nc")
    plot(ds, out / f"{args.which}_pareto.png", f"{args.which}: error against wall time")
    for key, value in attrs.items():
        print(f"  {key} = {value:.6g}")
    print(f"  {'case':28s} {'error':>8s} {'wall (s)':>9s}  front")
    for label, error, wall, front in zip(ds["case"].values, ds["error"].values, ds["wall_time"].values, ds["pareto"].values):
        print(f"  {label:28s} {100 * error:7.3f}% {wall:9.1f}  {'*' if front else ''}")
    print(f"wrote {out / (args.which + '.nc')}, {out / (args.which + '_pareto.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
