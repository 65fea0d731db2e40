"""Period and mean of an oscillating signal, e.g. a cantilever tip deflection.

Up-crossings of s(t) - mean are located by linear interpolation between samples; the
period is the mean spacing of successive up-crossings and the mean is the time average of
s over the whole periods between the first and the last up-crossing (trapezoid rule).
The mean used to find the crossings is refined once with the whole-period mean.
"""

from __future__ import annotations

import numpy as np


def _up_crossings(time_s: np.ndarray, signal: np.ndarray, level: float) -> np.ndarray:
    shifted = signal - level
    idx = np.flatnonzero((shifted[:-1] < 0.0) & (shifted[1:] >= 0.0))
    t0, t1 = time_s[idx], time_s[idx + 1]
    s0, s1 = shifted[idx], shifted[idx + 1]
    return t0 + (t1 - t0) * (-s0) / (s1 - s0)


def _whole_period_mean(time_s, signal, t_start, t_end) -> float:
    inside = (time_s >= t_start) & (time_s <= t_end)
    t = np.r_[t_start, time_s[inside], t_end]
    s = np.interp(t, time_s, signal)
    return float(np.trapezoid(s, t) / (t_end - t_start))


def period_and_mean(time_s, signal) -> tuple[float, float, int]:
    """(period in s, mean over whole periods, number of whole periods) of ``signal(time_s)``.

    Raises ValueError when the record holds fewer than one whole period.
    """
    time_s = np.asarray(time_s, dtype=float)
    signal = np.asarray(signal, dtype=float)
    level = float(np.mean(signal))
    for _ in range(2):
        crossings = _up_crossings(time_s, signal, level)
        if crossings.size < 2:
            raise ValueError("the record holds fewer than one whole period")
        level = _whole_period_mean(time_s, signal, crossings[0], crossings[-1])
    period = float(np.mean(np.diff(crossings)))
    return period, level, int(crossings.size - 1)
