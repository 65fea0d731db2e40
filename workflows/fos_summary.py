"""``summary.nc``: one row per SRF run and the factor of safety, and the printed report.

Variables (coordinate ``srf``): ``max_displacement`` (m, largest displacement of any
particle during the run), ``final_kinetic_energy`` (J m-1), ``status`` (stable / failed /
diverged), ``status_reason``, ``stop_time`` (s, < the stage duration when a run stopped
early), ``curvature`` (of the normalised curve, NaN at the ends), ``wall_time`` (s),
``run_start``/``run_end`` (s since the command started; NaN for runs reused from disk).
Scalar ``fos`` (NaN without a knee) with attributes ``fos_low``, ``fos_high``, ``knee_srf``,
``criterion``, ``second_criterion``, ``status_fos_low``/``status_fos_high`` and
``criteria_agree``.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np
import xarray as xr

from workflows import __version__
from workflows.fos_criterion import curvature


def summary_dataset(study, outcome, knee, status, stop_reason: str, floor_m: float) -> xr.Dataset:
    """The summary of a finished strength-reduction study (module doc)."""
    runs = outcome.runs
    srf = np.array([r["srf"] for r in runs], dtype=float)
    u = np.array([r["max_displacement_m"] for r in runs], dtype=float)
    usable = np.array([r["status"] != "diverged" for r in runs], dtype=bool)
    kappa = np.full(srf.size, np.nan)
    if usable.sum() >= 3:
        kappa[usable] = curvature(srf[usable], u[usable], floor_m)
    ds = xr.Dataset(coords={"srf": ("srf", srf, {"units": "1", "long_name": "strength reduction factor F"})})

    def column(name, values, units, long_name, dtype=float):
        ds[name] = ("srf", np.array(values, dtype=dtype), {"units": units, "long_name": long_name})

    column("max_displacement", u, "m", "largest displacement of any particle during the run")
    column("final_kinetic_energy", [r["final_kinetic_energy_j_per_m"] for r in runs], "J m-1",
           "kinetic energy at the end of the run, per metre of thickness")
    column("status", [r["status"] for r in runs], "1", "verdict of the run: stable, failed or diverged", object)
    column("status_reason", [r["status_reason"] for r in runs], "1", "why the run got its verdict", object)
    column("stop_time", [r["stop_time_s"] for r in runs], "s", "simulated time reached (early stop: < duration)")
    column("wall_time", [r["wall_time_s"] for r in runs], "s", "wall time of the run on its worker")
    column("run_start", [r["started_s"] for r in runs], "s",
           "wall clock when the run started on its worker, since the command started (NaN: reused run)")
    column("run_end", [r["finished_s"] for r in runs], "s",
           "wall clock when the run ended on its worker, since the command started (NaN: reused run)")
    column("n_steps", [r["n_steps"] for r in runs], "1", "explicit steps of the run", np.int64)
    ds["curvature"] = ("srf", kappa, {
        "units": "1", "long_name": "curvature of the SRF-displacement curve (normalised axes, log10 displacement)",
    })
    stage = study.strength_reduction
    ds["fos"] = ((), float(knee.fos), {
        "units": "1",
        "long_name": "factor of safety: middle of the bracket around the knee of the SRF-displacement curve",
        "fos_low": float(knee.fos_low),
        "fos_high": float(knee.fos_high),
        "knee_srf": float(knee.knee_srf),
        "criterion": "maximum curvature, convex upturns only: " + knee.reason,
        "second_criterion": "run verdicts (failed: past failure_displacement_m or still moving at the end): "
        + status.reason,
        "status_fos_low": float(status.fos_low),
        "status_fos_high": float(status.fos_high),
        "criteria_agree": int(bool(outcome.criteria_agree)),
        "verdict": outcome.verdict,
    })
    skipped = sorted(outcome.skipped.items())
    ds.attrs = {
        "title": f"spfem-fos strength-reduction summary of study {study.name}",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "n_particles": int(outcome.n_particles),
        "fos_tolerance": float(stage.fos_tolerance),
        "displacement_floor_m": float(floor_m),
        "search_stop": stop_reason,
        "srf_not_run": ", ".join(f"{f:g}" for f, _ in skipped),
        "srf_not_run_reason": "; ".join(f"{f:g}: {why}" for f, why in skipped),
        "gravity_reused": int(bool(outcome.gravity_reused)),
        "runs_started_ahead": int(outcome.guesses[0]),
        "runs_started_ahead_used": int(outcome.guesses[1]),
        "study": study.source_text,
        "spfem_fos_version": __version__,
        "created_utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
    return ds


def report_lines(outcome) -> list[str]:
    """The printed report: a table of SRF, largest displacement and status, then the FOS."""
    lines = [f"{'SRF':>8}  {'max disp (m)':>12}  {'t end (s)':>9}  status", f"{'-' * 8}  {'-' * 12}  {'-' * 9}  ------"]
    for r in outcome.runs:
        lines.append(f"{r['srf']:8.4f}  {r['max_displacement_m']:12.4g}  {r['stop_time_s']:9.3g}  {r['status']}")
    lines.append(outcome.verdict)
    if not math.isnan(outcome.status_high):
        lines.append(
            f"second criterion (run verdicts): FOS in [{outcome.status_low:.4g}, {outcome.status_high:.4g}]"
            + ("" if outcome.criteria_agree else "  <-- DISAGREES with the knee")
        )
    return lines
