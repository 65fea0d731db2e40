"""``refinement.nc``: the levels' FOS, the FOS at h -> 0 and its uncertainty, as declared in
``workflows.output.variables.REFINEMENT_FILE`` and ``REFINEMENT_FILE_ATTRIBUTES``; and ``study.nc``
of a sweep of refinement studies (``REFINED_SWEEP_FILE``)."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from workflows.output.stage_file import provenance
from workflows.output.variables import REFINED_SWEEP_FILE, REFINEMENT_FILE
from workflows.sweep.results import study_dataset, sweep_coordinates


def refinement_dataset(study, outcome) -> xr.Dataset:
    """The dataset of a finished refinement study (``outcome`` a ``study_type.RefinementOutcome``)."""
    var = REFINEMENT_FILE
    levels = outcome.levels
    ds = xr.Dataset(coords={"level": ("level", np.arange(len(levels), dtype=np.int64),
                                      {"long_name": "refinement level, coarsest first"})})

    def column(name, values, dtype=float):
        ds[name] = var[name](np.array(values, dtype=dtype))

    band = outcome.band
    nan = math.nan
    column("spacing", [level.spacing_m for level in levels])
    column("n_particles", [level.n_particles for level in levels], np.int64)
    column("fos", [level.fos for level in levels])
    column("fos_low", [level.fos_low for level in levels])
    column("fos_high", [level.fos_high for level in levels])
    column("n_runs", [level.n_runs for level in levels], np.int64)
    column("wall_time", [level.wall_time_s for level in levels])
    column("criteria_agree", [int(level.criteria_agree) for level in levels], np.int64)
    column("level_verdict", [level.verdict for level in levels], object)
    column("level_folder", [level.folder for level in levels], object)
    column("fos_fit", [float(band.fit.at(level.spacing_m)) if band is not None else nan for level in levels])
    ds["fos_limit"] = var["fos_limit"](nan if band is None else float(band.fos))
    ds["fos_uncertainty"] = var["fos_uncertainty"](nan if band is None else float(band.uncertainty))
    table = study.refinement
    ds.attrs = {
        "title": f"spfem-fos refinement study {study.name}",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "mode": table.kind,
        "band_low": nan if band is None else float(band.band_low),
        "band_high": nan if band is None else float(band.band_high),
        "band_trusted": int(band is not None and band.trusted),
        "fit_kind": "none" if band is None else band.fit.kind,
        "observed_order": nan if band is None else float(band.fit.order),
        "error_estimate": nan if band is None else float(band.error_estimate),
        "scatter": nan if band is None else float(band.scatter),
        "data_range": nan if band is None else float(band.data_range),
        "safety_factor": nan if band is None else float(band.safety_factor),
        "measured_scatter": outcome.measured_scatter if outcome.repeat is not None else nan,
        "repeat_fos": outcome.repeat.fos if outcome.repeat is not None else nan,
        "level_fos_tolerance": float(table.fos_tolerance),
        "band_reason": outcome.message if band is None else band.reason,
        "stop_reason": outcome.stop_reason,
        "verdict": outcome.verdict,
        **provenance(study),
    }
    return ds


def refined_sweep_dataset(study, cases, results: dict, refinements: dict) -> xr.Dataset:
    """``study.nc`` of a sweep with ``[refinement]``: the sweep's variables of each case's finest
    level (``results``, ``sweep.results.CaseResult`` by case id) and its band (``refinements``,
    ``RefinementOutcome`` or None by case id)."""
    ds = study_dataset(study, cases, results, {case.case_id: case.case_id for case in cases}, len(cases))
    dims, shape, _ = sweep_coordinates(study, cases)
    columns = {name: np.full(shape, np.nan) for name in ("fos_limit", "fos_uncertainty", "fos_band_low",
                                                         "fos_band_high", "finest_spacing")}
    columns["band_trusted"] = np.zeros(shape, dtype=np.int64)
    for case in cases:
        outcome, at = refinements[case.case_id], case.position
        if outcome is None:
            continue
        if outcome.levels:
            columns["finest_spacing"][at] = outcome.levels[-1].spacing_m
        band = outcome.band
        if band is not None:
            columns["fos_limit"][at], columns["fos_uncertainty"][at] = band.fos, band.uncertainty
            columns["fos_band_low"][at], columns["fos_band_high"][at] = band.band_low, band.band_high
            columns["band_trusted"][at] = int(band.trusted)
    for name, values in columns.items():
        ds[name] = REFINED_SWEEP_FILE[name].over(dims, values)
    ds.attrs["title"] = f"spfem-fos parameter study {study.name}: the FOS of every case, refined"
    return ds
