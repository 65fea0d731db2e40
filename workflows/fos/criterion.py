"""Picking the factor of safety from an SRF sweep: the abrupt increase of displacement.

**Knee** (method notes, section 3): the maximum curvature of the SRF-displacement curve of
the first, uniform sweep on normalised axes,

    x = (F - F_min) / (F_max - F_min),   y = (log10 u - min log10 u) / (max log10 u - min log10 u),
    kappa_i = y''_i / (1 + y'_i^2)^(3/2),

with y' and y'' from the three-point formulas on a non-uniform grid (h1 = x_i - x_(i-1),
h2 = x_(i+1) - x_i):

    y'_i  = (h1^2 y_(i+1) - h2^2 y_(i-1) + (h2^2 - h1^2) y_i) / (h1 h2 (h1 + h2)),
    y''_i = 2 (h1 y_(i+1) - (h1 + h2) y_i + h2 y_(i-1)) / (h1 h2 (h1 + h2)).

Only convex upturns (kappa > 0) count.  Displacements are floored at ``floor_m`` before
the log: below it a run has no mechanism, and decades of noise between 1e-7 and 1e-4 m
must not make a knee.

**Bracket.**  The curvature locates the upturn at the resolution of the sweep, but it is
not a well-posed target for refinement: at a jump between two samples, inserting samples
on both sides makes y' grow like 1/h and kappa at the foot *fall* like h, so a refined
curvature maximum drifts into the smooth stable branch.  The FOS is therefore the
*abrupt increase* that follows the knee: the consecutive pair of samples with the steepest
rise of log10 u per unit SRF between the knee and the first failed run after it (no FOS
without a failed run: a convex but stable curve only says the FOS is higher).
Refining inside that pair converges to a jump (its slope grows like 1/h) and, on a smooth
curve, to the steepest point of the rise.  ``fos`` is the middle of [fos_low, fos_high].

**Second criterion**: each run's own verdict (``workflows.fos.verdict``: ``failed`` when a
mechanism moved past the failure displacement or no equilibrium was found, else
``stable``).  Its bracket is [highest stable F below the lowest failed F, lowest failed F].
The two brackets should overlap; when they do not, the result says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from workflows.fos.verdict import FAILED, STABLE

SRF_GRID = 1e-4
"""SRF values are rounded to this (``search.sweep_values``, ``refinement_points``)."""


@dataclass(frozen=True)
class KneePick:
    """Where the curve turns up: the sample of maximum curvature and the one after it."""

    fos: float  # middle of [fos_low, fos_high]; NaN without a knee
    fos_low: float  # the knee sample
    fos_high: float  # the sample after it
    curvature: np.ndarray  # (n,) kappa at each sorted sample, NaN at the ends
    reason: str  # one line: how the knee was found, or why there is none


@dataclass(frozen=True)
class FosPick:
    """The FOS: the abrupt increase after the knee (module doc)."""

    fos: float  # middle of [fos_low, fos_high]; NaN when there is none
    fos_low: float
    fos_high: float
    knee_srf: float  # SRF of maximum curvature on the sweep (NaN: none)
    reason: str  # one line


@dataclass(frozen=True)
class StatusBracket:
    """The FOS bracket from the runs' own verdicts (second criterion)."""

    fos_low: float  # highest stable SRF below the lowest failed one (NaN: none)
    fos_high: float  # lowest failed SRF (NaN: none failed)
    non_monotone: list[float] = field(default_factory=list)  # stable SRFs above a failed one
    reason: str = ""


def curvature(srf: np.ndarray, displacement_m: np.ndarray, floor_m: float) -> np.ndarray:
    """kappa at each sample of the normalised curve (module doc); NaN at both ends.

    ``srf`` must be strictly increasing.
    """
    srf = np.asarray(srf, dtype=float)
    n = srf.size
    kappa = np.full(n, np.nan)
    if n < 3:
        return kappa
    if np.any(np.diff(srf) <= 0):
        raise ValueError("srf must be strictly increasing")
    x = (srf - srf[0]) / (srf[-1] - srf[0])
    log_u = np.log10(np.maximum(np.asarray(displacement_m, dtype=float), floor_m))
    span = log_u.max() - log_u.min()
    if span <= 0:
        return _ends_nan(n)
    y = (log_u - log_u.min()) / span
    h1 = x[1:-1] - x[:-2]
    h2 = x[2:] - x[1:-1]
    denominator = h1 * h2 * (h1 + h2)
    slope = (h1**2 * y[2:] - h2**2 * y[:-2] + (h2**2 - h1**2) * y[1:-1]) / denominator
    second = 2.0 * (h1 * y[2:] - (h1 + h2) * y[1:-1] + h2 * y[:-2]) / denominator
    kappa[1:-1] = second / (1.0 + slope**2) ** 1.5
    return kappa


def first_failed_sweep_srf(srf, status, srf_min: float, srf_step: float) -> float:
    """The lowest failed SRF on the sweep grid (srf_min + k srf_step), inf if none.  Runs above it
    were started before that failure was known: whether they finish before they are cancelled
    depends on the machine's load, so nothing deterministic may depend on them."""
    srf = np.asarray(srf, dtype=float)
    failed = srf[np.asarray(status).astype(str) == FAILED]
    steps = (failed - srf_min) / srf_step
    on_grid = failed[np.isclose(steps, np.round(steps), atol=1e-6)]
    return float(on_grid.min()) if on_grid.size else math.inf


def _ends_nan(n: int) -> np.ndarray:
    """Zero curvature inside, NaN at both ends (a flat curve)."""
    kappa = np.zeros(n)
    kappa[[0, -1]] = np.nan
    return kappa


def pick_knee(srf, displacement_m, floor_m: float) -> KneePick:
    """The maximum-curvature knee of the curve (module doc); samples in any order."""
    srf = np.asarray(srf, dtype=float)
    displacement_m = np.asarray(displacement_m, dtype=float)
    order = np.argsort(srf)
    srf, displacement_m = srf[order], displacement_m[order]
    kappa = curvature(srf, displacement_m, floor_m)
    nan = math.nan
    if srf.size < 3:
        return KneePick(nan, nan, nan, kappa, f"no knee: {srf.size} runs, at least 3 are needed")
    convex = np.where(kappa > 0, kappa, -np.inf)
    if not np.isfinite(convex).any():
        return KneePick(nan, nan, nan, kappa, "no knee: the curve has no convex upturn")
    knee = int(np.argmax(convex))
    low, high = float(srf[knee]), float(srf[knee + 1])
    return KneePick(
        0.5 * (low + high), low, high, kappa,
        f"maximum curvature {kappa[knee]:.3g} at SRF {low:g} (normalised axes, log10 displacement "
        f"floored at {floor_m:g} m); the upturn follows it",
    )


def log_rise(displacement_m, floor_m: float) -> np.ndarray:
    """log10 of the floored displacement: the quantity whose jump marks failure."""
    return np.log10(np.maximum(np.asarray(displacement_m, dtype=float), floor_m))


def pick_fos(sweep_srf, sweep_u, srf, u, status, floor_m: float) -> FosPick:
    """The knee of the sweep (``sweep_*``), then the largest rise of log10 u among all runs
    (``srf``, ``u``, ``status``) between the knee and the first failed run after it."""
    nan = math.nan
    knee = pick_knee(sweep_srf, sweep_u, floor_m)
    if math.isnan(knee.fos):
        return FosPick(nan, nan, nan, nan, knee.reason)
    order = np.argsort(np.asarray(srf, dtype=float))
    srf = np.asarray(srf, dtype=float)[order]
    y = log_rise(np.asarray(u, dtype=float)[order], floor_m)
    status = np.asarray(status, dtype=object)[order]
    failed_after = srf[(status == FAILED) & (srf > knee.fos_low)]
    if not failed_after.size:
        return FosPick(nan, nan, nan, knee.fos_low,
                       f"no run failed after the knee at SRF {knee.fos_low:g}: the FOS is above the runs made")
    end = failed_after.min()
    inside = np.flatnonzero((srf >= knee.fos_low) & (srf <= end))
    if inside.size < 2:
        return FosPick(nan, nan, nan, knee.fos_low, f"no run after the knee at SRF {knee.fos_low:g}")
    slope = np.diff(y[inside]) / np.diff(srf[inside])
    j = int(np.argmax(slope))
    low, high = float(srf[inside[j]]), float(srf[inside[j + 1]])
    reason = (
        f"knee (maximum curvature of the sweep) at SRF {knee.fos_low:g}; steepest rise of log10 displacement "
        f"after it ({slope[j]:.3g} decades per unit SRF) between SRF {low:g} and {high:g}"
    )
    return FosPick(0.5 * (low + high), low, high, knee.fos_low, reason)


def status_bracket(srf, status) -> StatusBracket:
    """Second criterion: bracket from the runs' verdicts; diverged runs are left out."""
    pairs = sorted((float(f), s) for f, s in zip(srf, status) if s in (STABLE, FAILED))
    failed = [f for f, s in pairs if s == FAILED]
    stable = [f for f, s in pairs if s == STABLE]
    nan = math.nan
    if not failed:
        top = f"{stable[-1]:g}" if stable else "-"
        return StatusBracket(nan, nan, [], f"no run failed (highest stable SRF {top})")
    lowest_failed = failed[0]
    below = [f for f in stable if f < lowest_failed]
    above = [f for f in stable if f > lowest_failed]
    if not below:
        return StatusBracket(nan, lowest_failed, above, f"every run failed, from SRF {lowest_failed:g}")
    reason = f"stable up to SRF {below[-1]:g}, failed from {lowest_failed:g}"
    if above:
        reason += f"; but stable again at {', '.join(f'{f:g}' for f in above)}"
    return StatusBracket(below[-1], lowest_failed, above, reason)


def brackets_agree(knee: FosPick, status: StatusBracket, tolerance: float) -> bool:
    """True when the FOS bracket and the status bracket overlap (within ``tolerance`` and the 1e-4 grid
    of the SRF values), or when neither brackets an FOS inside the runs (no run failed, or every
    run did: both put the FOS outside [srf_min, srf_max])."""
    if math.isnan(knee.fos):
        return math.isnan(status.fos_low)
    if math.isnan(status.fos_high):
        return False
    slack = tolerance + SRF_GRID
    low = status.fos_low if not math.isnan(status.fos_low) else -math.inf
    return knee.fos_low <= status.fos_high + slack and low <= knee.fos_high + slack


def refinement_points(low: float, high: float, tolerance: float, max_points: int) -> list[float]:
    """SRF values to run inside (low, high) so that the bracket shrinks below ``tolerance``
    in as few runs as bisection would need.

    Bisection needs n = ceil(log2(width / tolerance)) runs.  A round of k equally spaced
    points divides the width by k + 1; the largest k <= ``max_points`` with
    (k + 1) 2^(n - k) >= width / tolerance keeps the total at n runs, in fewer rounds
    (width 0.1, tolerance 0.01: rounds of 2, 1 and 1 points, 4 runs).  Values are rounded to 1e-4.
    """
    width = high - low
    if not width > tolerance + 1e-9:  # 1e-9: a halved 0.02 is 0.010000000000000009
        return []
    ratio = width / tolerance
    n_runs = max(1, math.ceil(math.log2(ratio) - 1e-9))
    k = 1
    for candidate in range(min(max_points, n_runs), 1, -1):
        if (candidate + 1) * 2.0 ** (n_runs - candidate) >= ratio - 1e-9:
            k = candidate
            break
    points = [round(low + width * (i + 1) / (k + 1), 4) for i in range(k)]
    return sorted({p for p in points if low < p < high})
