"""``fos_time.nc``: the FOS against time, as declared in ``workflows.output.variables.FOS_TIME_FILE``."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from workflows.output.stage_file import provenance
from workflows.output.variables import FOS_TIME_FILE
from workflows.transient.results import cumulative_rain_mm, rain_mm_h, reservoir_level_m
from workflows.transient.table import HOUR_S

FILE_NAME = "fos_time.nc"


def time_fos_reaches(times_h, fos, level: float) -> float:
    """The first time the FOS falls to ``level``, linear between the times either side (NaN: it does not;
    the first time if it starts below)."""
    for k, (t, f) in enumerate(zip(times_h, fos)):
        if f < level:
            if k == 0:
                return float(t)
            t0, f0 = times_h[k - 1], fos[k - 1]
            return float(t0 + (t - t0) * (f0 - level) / (f0 - f))
    return math.nan


def fos_time_dataset(study, flow, times_h, outcomes: dict, windows: dict, stop_below_fos) -> xr.Dataset:
    """The dataset of the FOS against time (``outcomes``: case id -> FosOutcome, in time order)."""
    var = FOS_TIME_FILE
    fos = [o.fos for o in outcomes.values()]
    window = [windows.get(cid) for cid in outcomes]
    saved_h = flow.solution.times_s / HOUR_S
    water_in = np.interp(times_h, saved_h, flow.solution.water_in_m2)
    data = {
        "time": var["time"](np.array(times_h, dtype=float)),
        "fos": var["fos"](np.array(fos, dtype=float)),
        "fos_low": var["fos_low"](np.array([o.fos_low for o in outcomes.values()], dtype=float)),
        "fos_high": var["fos_high"](np.array([o.fos_high for o in outcomes.values()], dtype=float)),
        "runs": var["runs"](np.array([len(o.runs) for o in outcomes.values()], dtype=np.int32)),
        "window_low": var["window_low"](np.array([math.nan if w is None else w[0] for w in window])),
        "window_high": var["window_high"](np.array([math.nan if w is None else w[1] for w in window])),
        "rain_intensity": var["rain_intensity"](rain_mm_h(flow, times_h)),
        "cumulative_rain": var["cumulative_rain"](cumulative_rain_mm(flow, times_h)),
        "reservoir_level": var["reservoir_level"](reservoir_level_m(flow, times_h)),
        "water_in": var["water_in"](water_in),
    }
    ds = xr.Dataset(data)
    all_times = study.transient.fos_times()
    ds.attrs = {
        "title": f"spfem-fos FOS against time of study {study.name}",
        "study_name": study.name,
        "time_fos_one_h": time_fos_reaches(times_h, fos, 1.0),
        "stop_below_fos": math.nan if stop_below_fos is None else float(stop_below_fos),
        "stopped_at_h": float(times_h[-1]) if len(times_h) < len(all_times) else math.nan,
        **provenance(study),
    }
    return ds
