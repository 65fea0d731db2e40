"""Numerical stability stress suite: try to break the numerics, and say what happened.

    python -m verification.stress_suite [--out stress.nc]

Every case has an expected outcome, and the suite measures whether it got it:

- ``stable``: ran to the end with finite state, no inverted element after a step, the
  particle mass unchanged to the bit, and (undamped, no prescribed motion) the energy
  balance closed;
- ``refused``: the settings were rejected before any step, with a message;
- ``diverged``: the run was stopped by the divergence detection (never silent garbage).

Cases: CFL factor 0.1 ... past the stability limit (refused by the settings; forced past it
by setting dt directly, the detection must stop it), beta 0 ... 1, nu up to 0.49, phi up to
45 deg with c = 0, a jittered cloud, a cloud with two spacings (4:1) in one domain, the beam
for its full 4 s (energy with beta = 0; the energy the stabilisation removes with beta > 0),
and both collapses with many remeshes.  Prints a table of case, outcome and measured
quantity; the slow test ``tests/test_stress_suite.py`` requires every outcome as expected.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.cloud import particles_in_polygon
from spfem_core.divergence import DivergenceError
from spfem_core.mesh import count_inverted
from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.timestep import UnstableTimeStepError, max_stable_cfl
from verification.oscillation import period_and_mean
from verification.scenes import beam_scene, column_scene
from workflows.output.writing import write_dataset
from workflows.scene import build_scene, solver_settings
from workflows.stages.running import begin_stage
from workflows.study import parse_study

ROOT = Path(__file__).resolve().parents[1]


@dataclass
class StressResult:
    case: str
    expected: str
    outcome: str
    measured: str
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.outcome == self.expected


# ------------------------------------------------------------------------------ scenes


def _beam(spacing_m=0.05, jitter=0.0, nu=0.25):
    return beam_scene(spacing_m, jitter=jitter, seed=1, poisson_ratio=nu)


def _column(node_xy_m, spacing_m, nu):
    return column_scene(spacing_m, nu=nu, node_xy_m=node_xy_m)


def _checked_run(sim, duration_s, parts=4, damping=0.0):
    """Run in parts, checking after each: finite state, no inverted element.  (series list, note)."""

    mass0 = sim.nodes.mass_kg.sum()
    series = []
    for _ in range(parts):
        series.append(sim.run(duration_s / parts, damping=damping, record_interval_s=duration_s / parts / 50))
        if not (np.all(np.isfinite(sim.nodes.xy_m)) and np.all(np.isfinite(sim.nodes.stress_pa))):
            return series, "non-finite state"
        if count_inverted(sim.nodes.xy_m, sim.mesh.elem_nodes):
            return series, "inverted element after a step"
    if sim.nodes.mass_kg.sum() != mass0:
        return series, "mass changed"
    return series, ""


def _mechanical_terms(series) -> np.ndarray:
    """(n_rec, 3) kinetic, strain and gravity potential energy (J/m)."""
    return np.column_stack([series.energy(name) for name in ("kinetic", "strain", "gravity_potential")])


def _energy_drift(series) -> tuple[float, float]:
    """(|kinetic + strain + gravity + dissipated change| summed over parts, largest |energy term|)."""
    drift = sum(abs(s.energy_total_j_per_m[-1] - s.energy_total_j_per_m[0]) for s in series)
    scale = max(float(np.abs(_mechanical_terms(s)).max()) for s in series)
    return drift, scale


# ------------------------------------------------------------------------------ cases


def case_cfl(cfl: float, beta: float = 0.1, force: bool = False) -> StressResult:
    """The beam at h = 0.05 m for 1 s at this cfl; ``force`` sets dt past the refusal."""

    limit = max_stable_cfl(beta)
    name = f"beam cfl {cfl:g} (beta {beta:g}, accepted <= {limit:.3g})" + (", forced" if force else "")
    expected = "stable" if cfl <= limit else ("diverged" if force else "refused")
    try:
        sim = Simulation(_beam(), SolverSettings(cfl=min(cfl, limit) if force else cfl, stabilisation_beta=beta))
    except UnstableTimeStepError as error:
        return StressResult(name, expected, "refused", str(error)[:90])
    if force:
        sim.dt_s = cfl * sim.critical_dt_s
    try:
        series, problem = _checked_run(sim, 1.0)
    except DivergenceError as error:
        return StressResult(name, expected, "diverged", f"stopped at step {error.step}: {error.reason[:60]}")
    if problem:
        return StressResult(name, expected, "garbage", problem)
    drift, scale = _energy_drift(series)
    return StressResult(name, expected, "stable", f"energy balance closed to {100 * drift / scale:.2f}% of its scale")


def case_beta(beta: float) -> StressResult:

    sim = Simulation(_beam(), SolverSettings(cfl=0.5 * 1.0 / (1.0 + beta), stabilisation_beta=beta))
    try:
        series, problem = _checked_run(sim, 1.0)
    except DivergenceError as error:
        return StressResult(f"beam beta {beta:g}", "stable", "diverged", error.reason[:80])
    removed = sum(s.energy("stabilisation_dissipated")[-1] for s in series)
    _, scale = _energy_drift(series)
    outcome = "garbage" if problem else "stable"
    return StressResult(f"beam beta {beta:g}", "stable", outcome,
                        problem or f"stabilisation removed {100 * removed / scale:.2f}% of the energy scale in 1 s")


def case_column(nu: float, spacings=(0.25,)) -> StressResult:
    """Elastic column relaxed under gravity: sigma_yy against -rho g (H - y) at 0.1H-0.8H."""

    if len(spacings) == 1:
        xy = particles_in_polygon([[0, 0], [2, 0], [2, 10], [0, 10]], spacings[0])
        name = f"column nu {nu:g}"
    else:  # bottom half coarse, top half fine, joined at y = 5
        coarse = particles_in_polygon([[0, 0], [2, 0], [2, 5], [0, 5]], spacings[0])
        fine = particles_in_polygon([[0, 5], [2, 5], [2, 10], [0, 10]], spacings[1])
        fine = fine[fine[:, 1] > 5.0 + 1e-9]
        xy = np.concatenate([coarse, fine])
        name = f"column, two spacings {spacings[0]:g} / {spacings[1]:g} m"

    sim = Simulation(_column(xy, max(spacings), nu), SolverSettings(cfl=0.5, stabilisation_beta=0.1))
    try:
        series = sim.relax(damping=0.7, tolerance=1e-5, max_duration_s=40.0)
    except DivergenceError as error:
        return StressResult(name, "stable", "diverged", error.reason[:80])
    y0 = sim.initial_xy_m[:, 1]
    band = (y0 >= 1.0) & (y0 <= 8.0)
    error = np.max(np.abs(sim.nodes.stress_pa[band, 1] / (-2000.0 * 10.0 * (10.0 - y0[band])) - 1.0))
    finite = np.all(np.isfinite(sim.nodes.stress_pa))
    outcome = "stable" if finite and series.converged else ("garbage" if not finite else "not converged")
    return StressResult(name, "stable", outcome, f"sigma_yy within {100 * error:.2f}% of rho g (H - y), "
                        f"{sim.n_particles} particles, {series.n_steps} steps")


def case_jitter() -> StressResult:

    scene = _beam(0.04, jitter=0.25)
    tip = scene.nearest_particle(2.0, 0.2)
    sim = Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1))
    try:
        series = sim.run(2.0, record_interval_s=1e-3, monitor_nodes=[tip])
    except DivergenceError as error:
        return StressResult("beam, jittered cloud (0.25 h)", "stable", "diverged", error.reason[:80])
    period, mean_uy, _ = period_and_mean(series.time_s, series.monitor_displacement_m[:, 0, 1])
    return StressResult("beam, jittered cloud (0.25 h)", "stable", "stable" if math.isfinite(period) else "garbage",
                        f"period {period:.4f} s, mean deflection {-mean_uy:.4f} m (lattice h 0.04: 0.599 s)")


def case_full_beam(beta: float) -> StressResult:

    sim = Simulation(_beam(0.04), SolverSettings(cfl=0.5, stabilisation_beta=beta))
    name = f"beam 4 s, beta {beta:g}"
    try:
        series = sim.run(4.0, record_interval_s=2e-3)
    except DivergenceError as error:
        return StressResult(name, "stable", "diverged", error.reason[:80])
    mechanical = _mechanical_terms(series).sum(axis=1)
    scale = float(np.abs(series.energy("strain")).max())
    if beta == 0.0:
        change = float(np.abs(mechanical - mechanical[0]).max()) / scale
        outcome = "stable" if change < 0.01 else "energy drift"
        return StressResult(name, "stable", outcome, f"kinetic + strain + gravity within {100 * change:.3f}% "
                            "of the peak strain energy over 4 s")
    removed = float(series.energy("stabilisation_dissipated")[-1])
    closed = abs(series.energy_total_j_per_m[-1] - series.energy_total_j_per_m[0]) / scale
    return StressResult(name, "stable", "stable" if closed < 0.01 else "energy drift",
                        f"stabilisation removed {100 * removed / scale:.2f}% of the peak strain energy; "
                        f"balance closed to {100 * closed:.3f}%")


def _with_spacing(study_text: str, spacing_m: float) -> str:
    """The study text with its ``spacing_m`` line set to ``spacing_m`` (whatever it was)."""
    line = next(row for row in study_text.splitlines() if row.startswith("spacing_m"))
    return study_text.replace(line, f"spacing_m = {spacing_m}", 1)


def case_collapse(kind: str, friction_deg: float | None = None) -> StressResult:

    if kind == "granular":
        text = _with_spacing((ROOT / "studies" / "collapse_granular.toml").read_text(), 0.005)
        duration = 0.6
    else:
        text = _with_spacing((ROOT / "studies" / "collapse_cohesive.toml").read_text(), 0.1)
        duration = 2.5
    name = f"{kind} collapse"
    if friction_deg is not None:
        text = text.replace("friction_deg = 19.8", f"friction_deg = {friction_deg}")
        name += f", phi {friction_deg:g} deg, c = 0"
    study = parse_study(text)
    sim = Simulation(build_scene(study), solver_settings(study))
    begin_stage(study, sim, 0)
    sim.relax(damping=0.7, tolerance=1e-4, max_duration_s=5.0)
    begin_stage(study, sim, 1)
    try:
        series, problem = _checked_run(sim, duration, parts=6)
    except DivergenceError as error:
        return StressResult(name, "stable", "diverged", error.reason[:80])
    drift = sum(s.energy_total_j_per_m[-1] - s.energy_total_j_per_m[0] for s in series)
    released = sum(-(s.energy("gravity_potential")[-1] - s.energy("gravity_potential")[0]) for s in series)
    rebuilds = sum(s.n_remesh for s in series)
    closed = abs(drift) / max(released, 1e-30)
    outcome = "garbage" if problem else ("stable" if closed < 0.03 else "energy drift")
    return StressResult(name, "stable", outcome, problem or f"{rebuilds} rebuilds, mass exact, energy budget closed "
                        f"to {100 * closed:.3f}% of {released:.3g} J/m released")


def all_cases():
    """(label, callable) of every case, cheapest first."""
    cases = [(f"cfl {c}", lambda c=c: case_cfl(c)) for c in (0.1, 0.5, 0.9, 0.95, 1.5)]
    cases += [("cfl 2.0 forced", lambda: case_cfl(2.0, force=True)), ("cfl 3.0 forced", lambda: case_cfl(3.0, force=True))]
    cases += [(f"beta {b}", lambda b=b: case_beta(b)) for b in (0.0, 0.1, 0.3, 1.0)]
    cases += [(f"nu {nu}", lambda nu=nu: case_column(nu)) for nu in (0.3, 0.45, 0.49)]
    cases += [("two spacings", lambda: case_column(0.3, spacings=(0.25, 0.0625)))]
    cases += [("jitter", case_jitter)]
    cases += [(f"full beam beta {b}", lambda b=b: case_full_beam(b)) for b in (0.0, 0.1)]
    cases += [("granular", lambda: case_collapse("granular")),
              ("granular phi 45", lambda: case_collapse("granular", friction_deg=45.0)),
              ("cohesive", lambda: case_collapse("cohesive"))]
    return cases


def run_suite(progress=print) -> list[StressResult]:
    results = []
    for _, make in all_cases():
        start = time.perf_counter()
        result = make()
        result.wall_s = time.perf_counter() - start
        progress(f"{'ok ' if result.ok else 'BAD'} {result.case:48s} {result.outcome:9s} {result.measured}")
        results.append(result)
    return results


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.stress_suite", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="also write the table as netCDF here")
    args = parser.parse_args(argv)
    results = run_suite(lambda line: print(line, flush=True))
    if args.out is not None:


        ds = xr.Dataset(coords={"case": ("case", np.array([r.case for r in results], dtype=object))})
        for name in ("expected", "outcome", "measured"):
            ds[name] = ("case", np.array([getattr(r, name) for r in results], dtype=object))
        ds["wall_time"] = ("case", np.array([r.wall_s for r in results]), {"units": "s"})
        write_dataset(ds, args.out)
    bad = [r for r in results if not r.ok]
    print(f"{len(results) - len(bad)} of {len(results)} cases as expected")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
