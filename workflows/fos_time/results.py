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


def bracket(outcome) -> tuple[float, float, float]:
    """(FOS, low, high) of a case's outcome (``fos.summary.FosOutcome``); without a FOS (every run stable,
    or every run failed) its bounds from the runs: the highest stable SRF below the lowest failed one
    (NaN: none) and the lowest failed SRF (NaN: none)."""
    if math.isfinite(outcome.fos):
        return outcome.fos, outcome.fos_low, outcome.fos_high
    failed = [r.srf for r in outcome.runs if r.status == "failed"]
    high = min(failed) if failed else math.nan
    stable = [r.srf for r in outcome.runs if r.status == "stable" and not r.srf >= high]
    return math.nan, max(stable) if stable else math.nan, high


def below(outcome, level: float) -> bool:
    """Whether a case's FOS is below ``level``: its FOS, or without one, its lowest failed SRF at or below it."""
    fos, _, high = bracket(outcome)
    return fos < level if math.isfinite(fos) else math.isfinite(high) and high <= level


def time_fos_reaches(times_h, fos, level: float) -> float:
    """The first time the FOS falls to ``level``, linear between the times either side (NaN: it does not;
    the first time if it starts below).  ``fos``: each time's FOS, or without one its upper bound (+inf when
    every run was stable)."""
    for k, (t, f) in enumerate(zip(times_h, fos)):
        if f < level:
            if k == 0:
                return float(t)
            t0, f0 = times_h[k - 1], fos[k - 1]
            return float(t0 + (t - t0) * (f0 - level) / (f0 - f))
    return math.nan


def upper_values(outcomes) -> list[float]:
    """Each case's FOS, or without one its upper bound (the lowest failed SRF; +inf: every run stable)."""
    values = []
    for outcome in outcomes:
        fos, _, high = bracket(outcome)
        values.append(fos if math.isfinite(fos) else high if math.isfinite(high) else math.inf)
    return values


def fos_time_dataset(study, flow, times_h, outcomes: dict, windows: dict, stop_below_fos) -> xr.Dataset:
    """The dataset of the FOS against time (``outcomes``: case id -> FosOutcome, in time order)."""
    var = FOS_TIME_FILE
    brackets = np.array([bracket(o) for o in outcomes.values()], dtype=float).reshape(-1, 3)
    window = [windows.get(cid) for cid in outcomes]
    saved_h = flow.solution.times_s / HOUR_S
    water_in = np.interp(times_h, saved_h, flow.solution.water_in_m2)
    data = {
        "time": var["time"](np.array(times_h, dtype=float)),
        "fos": var["fos"](brackets[:, 0]),
        "fos_low": var["fos_low"](brackets[:, 1]),
        "fos_high": var["fos_high"](brackets[:, 2]),
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
        "time_fos_one_h": time_fos_reaches(times_h, upper_values(outcomes.values()), 1.0),
        "stop_below_fos": math.nan if stop_below_fos is None else float(stop_below_fos),
        "stopped_at_h": float(times_h[-1]) if len(times_h) < len(all_times) else math.nan,
        **provenance(study),
    }
    return ds
