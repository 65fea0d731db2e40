"""``refinement.nc``: the levels' FOS and the extrapolation, as declared in
``workflows.output.variables.REFINEMENT_FILE`` and ``REFINEMENT_FILE_ATTRIBUTES``; and ``study.nc``
of a sweep of refinement studies (``REFINED_SWEEP_FILE``)."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from workflows.output.stage_file import provenance
from workflows.output.variables import REFINED_SWEEP_FILE, REFINEMENT_FILE


def refinement_dataset(study, outcome) -> xr.Dataset:
    """The dataset of a finished refinement study (``outcome`` a ``study_type.RefinementOutcome``)."""
    var = REFINEMENT_FILE
    levels = outcome.levels
    ds = xr.Dataset(coords={"level": ("level", np.arange(len(levels), dtype=np.int64),
                                      {"long_name": "refinement level, coarsest first"})})

    def column(name, values, dtype=float):
        ds[name] = var[name](np.array(values, dtype=dtype))

    column("spacing", [level.spacing_m for level in levels])
    column("n_particles", [level.n_particles for level in levels], np.int64)
    column("fos", [level.fos for level in levels])
    column("fos_low", [level.fos_low for level in levels])
    column("fos_high", [level.fos_high for level in levels])
    column("n_runs", [level.n_runs for level in levels], np.int64)
    column("wall_time", [level.wall_time_s for level in levels])
    column("criteria_agree", [int(level.criteria_agree) for level in levels], np.int64)
    column("level_verdict", [level.verdict for level in levels], object)
    column("level_folder", [f"{k}_h={level.spacing_m:g}" for k, level in enumerate(levels)], object)
    x = outcome.extrapolation
    nan = math.nan
    ds["fos_extrapolated"] = var["fos_extrapolated"](nan if x is None else float(x.fos))
    ds.attrs = {
        "title": f"spfem-fos refinement study {study.name}",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "extrapolation_status": "none" if x is None else x.status,
        "band_low": nan if x is None else float(x.band_low),
        "band_high": nan if x is None else float(x.band_high),
        "observed_order": nan if x is None else float(x.observed_order),
        "gci": nan if x is None else float(x.gci),
        "safety_factor": float(study.refinement.safety_factor),
        "level_fos_tolerance": float(study.refinement.fos_tolerance),
        "extrapolation_reason": outcome.message if x is None else x.reason,
        "verdict": outcome.verdict,
        **provenance(study),
    }
    return ds


def refined_sweep_dataset(study, cases, results: dict, refinements: dict) -> xr.Dataset:
    """``study.nc`` of a sweep with ``[refinement]``: the sweep's variables of each case's finest
    level (``results``, ``sweep.results.CaseResult`` by case id) and its extrapolation
    (``refinements``, ``RefinementOutcome`` or None by case id)."""
    from workflows.sweep.results import study_dataset, sweep_coordinates

    ds = study_dataset(study, cases, results, {case.case_id: case.case_id for case in cases}, len(cases))
    dims, shape, _ = sweep_coordinates(study, cases)
    columns = {"fos_extrapolated": np.full(shape, np.nan), "fos_band_low": np.full(shape, np.nan),
               "fos_band_high": np.full(shape, np.nan), "extrapolation_status": np.full(shape, "none", dtype=object),
               "finest_spacing": np.full(shape, np.nan)}
    for case in cases:
        outcome, at = refinements[case.case_id], case.position
        if outcome is None:
            continue
        if outcome.levels:
            columns["finest_spacing"][at] = outcome.levels[-1].spacing_m
        x = outcome.extrapolation
        if x is not None:
            columns["fos_extrapolated"][at] = x.fos
            columns["fos_band_low"][at], columns["fos_band_high"][at] = x.band_low, x.band_high
            columns["extrapolation_status"][at] = x.status
    for name, values in columns.items():
        ds[name] = REFINED_SWEEP_FILE[name].over(dims, values)
    ds.attrs["title"] = f"spfem-fos parameter study {study.name}: the FOS of every case, refined"
    return ds
