"""``summary.nc``: one row per SRF run and the factor of safety.

Variables and attributes as declared in :data:`workflows.output.variables.SUMMARY_FILE`,
``FOS_ATTRIBUTES`` and ``SUMMARY_FILE_ATTRIBUTES`` (coordinate ``srf``; scalar ``fos``).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from workflows.fos.criterion import curvature, first_failed_sweep_srf
from workflows.fos.verdict import DIVERGED
from workflows.output.stage_file import provenance
from workflows.output.variables import SUMMARY_FILE


def summary_dataset(study, outcome, knee, status, stop_reason: str, floor_m: float) -> xr.Dataset:
    """The summary of a finished strength-reduction study (``outcome`` a ``FosOutcome``, ``knee``
    the ``criterion.FosPick`` and ``status`` the ``criterion.StatusBracket`` of its runs)."""
    var = SUMMARY_FILE
    runs = outcome.runs
    srf = np.array([r["srf"] for r in runs], dtype=float)
    u = np.array([r["max_displacement_m"] for r in runs], dtype=float)
    stage = study.strength_reduction
    ceiling = first_failed_sweep_srf(srf, [r["status"] for r in runs], stage.srf_min, stage.srf_step)
    # the curvature of the runs the search decided with: not of runs that finished only by timing
    usable = np.array([r["status"] != DIVERGED for r in runs], dtype=bool) & (srf <= ceiling)
    kappa = np.full(srf.size, np.nan)
    if usable.sum() >= 3:
        kappa[usable] = curvature(srf[usable], u[usable], floor_m)
    ds = xr.Dataset(coords={"srf": var["srf"](srf)})

    def column(name, key, dtype=float):
        ds[name] = var[name](np.array([r[key] for r in runs], dtype=dtype))

    ds["max_displacement"] = var["max_displacement"](u)
    column("final_kinetic_energy", "final_kinetic_energy_j_per_m")
    column("status", "status", object)
    column("status_reason", "status_reason", object)
    column("stop_time", "stop_time_s")
    column("wall_time", "wall_time_s")
    column("run_start", "started_s")
    column("run_end", "finished_s")
    column("n_steps", "n_steps", np.int64)
    ds["curvature"] = var["curvature"](kappa)
    ds["fos"] = var["fos"](
        float(knee.fos),
        fos_low=float(knee.fos_low),
        fos_high=float(knee.fos_high),
        knee_srf=float(knee.knee_srf),
        criterion="maximum curvature, convex upturns only: " + knee.reason,
        second_criterion="run verdicts (failed: a mechanism moved past failure_displacement_m, or no "
        "equilibrium at the end): "
        + status.reason,
        status_fos_low=float(status.fos_low),
        status_fos_high=float(status.fos_high),
        criteria_agree=int(bool(outcome.criteria_agree)),
        verdict=outcome.verdict,
    )
    skipped = sorted(outcome.skipped.items())
    stage = study.strength_reduction
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
        **provenance(study),
    }
    return ds
