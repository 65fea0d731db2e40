"""``refinement.nc``: the levels' FOS and the extrapolation, as declared in
``workflows.output.variables.REFINEMENT_FILE`` and ``REFINEMENT_FILE_ATTRIBUTES``."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from workflows.output.stage_file import provenance
from workflows.output.variables import REFINEMENT_FILE


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
