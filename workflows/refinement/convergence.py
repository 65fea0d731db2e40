"""The factor of safety as h -> 0 and its discretisation uncertainty from noisy levels, by the
least-squares procedure of Eca & Hoekstra (2014), "A procedure for the estimation of the numerical
uncertainty of CFD calculations based on grid refinement studies", J. Comput. Phys. 262:104-130
(the vocabulary of ASME V&V 20-2009: the numerical uncertainty U of a computed value).

With n >= 4 levels (h_i, f_i), h_1 the finest, expansions of the error are fitted by least
squares, each unweighted and weighted (w_i proportional to 1 / h_i, normalised to sum 1), the
weighting with the smaller standard deviation kept:

    f_i = f0 + a h_i^p           (p free: the observed order; 3 parameters)
    f_i = f0 + a1 h_i            (first order)
    f_i = f0 + a1 h_i + a2 h_i^2 (first and second order; 3 parameters)

    sigma = sqrt(n sum w_i (f_i - fit_i)^2 / (n - n_p))     (unweighted: w_i = 1 / n)

The method's theoretical order is 1 (the strength of a shear band smeared over a few spacings; the
FOS converges from above at first order, docs/verification.md), and the rules follow Eca & Hoekstra
for it, on the safe side of a FOS: the free-order fit is used when its order lies in
[P_MIN, P_MAX]; faster than P_MAX (noise that bends the levels), and slower than P_MIN, the
first-order expansions (FALLBACK) are fitted instead, the one with the smaller sigma gives f0, and
the error estimate is the larger of theirs, so that an order the method cannot have does not shrink
the band.  With eps = |f_1 - f0| the error estimate of the finest level, the data range
Delta = (f_max - f_min) / (n - 1) and the scatter s = max(sigma, the measured scatter, the levels'
search resolution),

    U = Fs eps + s + |f_1 - fit_1|                 s < Delta
    U = 3 s / Delta (eps + s + |f_1 - fit_1|)      s >= Delta (the levels differ by less than their noise)

with Fs = 1.25 for an order of at least P_MIN and 3 otherwise.  Eca & Hoekstra's U is the
uncertainty of the finest level's f_1; the band here is placed about f0, [f0 - U, f0 + U], which
holds f_1 too (U > eps) and reaches further on the side the levels converge from: a FOS that falls
with h (the usual case) gets a lower end below that of [f_1 - U, f_1 + U].  The band is trusted
(``DiscretisationBand.trusted``) when Fs = 1.25: levels that converge (order at least P_MIN) by
more than their scatter; otherwise the band says why it is not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from workflows.refinement.table import MIN_LEVELS

P_MIN, P_MAX = 0.5, 1.5
"""Observed orders taken as they are for a first-order method (Eca & Hoekstra take [0.5, 2] for a
second-order one): faster convergence than 1.5 is read as noise, slower than 0.5 as no convergence.
On noisy first-order sequences these rules hold the limit in 99% of the cases of
``tests/test_refinement.py`` (their 95% aimed at), where [0.5, 2] with Eca & Hoekstra's choice by
sigma held it in 93%, missing on the high side (the dangerous one for a FOS)."""
TRUSTED_SAFETY_FACTOR = 1.25
UNTRUSTED_SAFETY_FACTOR = 3.0
FREE, FIRST, SECOND, FIRST_AND_SECOND = "free order", "first order", "second order", "first and second order"
FALLBACK = (FIRST, FIRST_AND_SECOND)
"""The fixed-order expansions of a first-order method, fitted when the observed order is out of range."""


@dataclass(frozen=True)
class Fit:
    """One least-squares fit of the levels."""

    kind: str  # FREE, FIRST, SECOND or FIRST_AND_SECOND
    fos_limit: float  # f0
    order: float  # p (FREE), 1, 2, or NaN (FIRST_AND_SECOND)
    coefficients: tuple[float, ...]  # a (or a1, a2)
    sigma: float  # its standard deviation
    weighted: bool

    def at(self, spacing_m) -> np.ndarray:
        """The fitted FOS at the spacings."""
        h = np.asarray(spacing_m, dtype=float)
        if self.kind == FIRST_AND_SECOND:
            return self.fos_limit + self.coefficients[0] * h + self.coefficients[1] * h**2
        return self.fos_limit + self.coefficients[0] * h**self.order


@dataclass(frozen=True)
class DiscretisationBand:
    """The FOS as h -> 0, its uncertainty U and how they were found (module doc)."""

    fos: float  # f0
    uncertainty: float  # U: the FOS lies in fos -+ U (95%)
    fit: Fit
    error_estimate: float  # eps = |f_1 - f0|
    scatter: float  # s
    data_range: float  # Delta
    safety_factor: float  # Fs
    trusted: bool
    reason: str  # one line: how, or why the band is not to be trusted

    @property
    def band_low(self) -> float:
        return self.fos - self.uncertainty

    @property
    def band_high(self) -> float:
        return self.fos + self.uncertainty

    @property
    def relative_uncertainty(self) -> float:
        return self.uncertainty / self.fos


def _weights(h: np.ndarray, weighted: bool) -> np.ndarray:
    w = 1.0 / h if weighted else np.ones_like(h)
    return w / w.sum()


def _linear_fit(columns: np.ndarray, f: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, float]:
    """Weighted least squares of f on the columns (the first a column of ones): (coefficients, sum of
    w r^2)."""
    root = np.sqrt(w)
    coefficients, *_ = np.linalg.lstsq(columns * root[:, None], f * root, rcond=None)
    residual = f - columns @ coefficients
    return coefficients, float(np.sum(w * residual**2))


def _sigma(sum_wr2: float, n: int, parameters: int) -> float:
    return math.sqrt(n * sum_wr2 / (n - parameters)) if n > parameters else math.inf


def _fixed_fit(kind: str, h: np.ndarray, f: np.ndarray, weighted: bool) -> Fit:
    w = _weights(h, weighted)
    powers = {FIRST: (1.0,), SECOND: (2.0,), FIRST_AND_SECOND: (1.0, 2.0)}[kind]
    columns = np.column_stack([np.ones_like(h)] + [h**p for p in powers])
    coefficients, sum_wr2 = _linear_fit(columns, f, w)
    order = powers[0] if len(powers) == 1 else math.nan
    return Fit(kind, float(coefficients[0]), order, tuple(float(c) for c in coefficients[1:]),
               _sigma(sum_wr2, h.size, columns.shape[1]), weighted)


def _free_fit(h: np.ndarray, f: np.ndarray, weighted: bool) -> Fit:
    """f0 + a h^p, p minimising the weighted residual over (0, 8] (f0 and a linear for each p: the
    closed form of a weighted straight-line fit on x = (h / h_max)^p, on a grid, then refined)."""
    w = _weights(h, weighted)
    scale = h.max()

    def residuals(p):
        x = (h / scale) ** np.atleast_1d(p)[:, None]  # (grid, n)
        mean_x, mean_f = x @ w, f @ w
        dx, df = x - mean_x[:, None], f - mean_f
        slope = (dx * df) @ w / np.maximum((dx * dx) @ w, 1e-300)
        return (((df - slope[:, None] * dx) ** 2) @ w), mean_f - slope * mean_x, slope

    grid = np.linspace(0.05, 8.0, 160)
    start = float(grid[int(np.argmin(residuals(grid)[0]))])
    best = minimize_scalar(lambda p: float(residuals(p)[0][0]), bounds=(max(start - 0.05, 0.01), min(start + 0.05, 8.0)),
                           method="bounded", options={"xatol": 1e-8})
    p = float(best.x) if best.fun <= residuals(start)[0][0] else start
    sum_wr2, intercept, slope = (float(value[0]) for value in residuals(p))
    return Fit(FREE, intercept, p, (slope / scale**p,), _sigma(sum_wr2, h.size, 3), weighted)


def _best(fits: list[Fit]) -> Fit:
    return min(fits, key=lambda fit: fit.sigma)


def discretisation_band(spacings_m, fos, measured_scatter: float = 0.0, resolution: float = 0.0) -> DiscretisationBand:
    """The band of the module doc from the levels (``spacings_m``, ``fos``: one value each, any order;
    at least ``MIN_LEVELS``).  ``measured_scatter``: the standard deviation of one level's FOS over
    clouds that differ only by their jitter (0: not measured); ``resolution``: how far a level's FOS
    may lie from its own converged value by the search alone (half its FOS bracket)."""
    h = np.asarray(spacings_m, dtype=float)
    f = np.asarray(fos, dtype=float)
    if h.size != f.size or h.size < MIN_LEVELS:
        raise ValueError(f"discretisation_band: at least {MIN_LEVELS} levels with an FOS each, got {h.size}")
    if not (np.all(np.isfinite(h)) and np.all(h > 0.0) and np.all(np.isfinite(f))):
        raise ValueError("discretisation_band: spacings must be positive and every FOS finite")
    if np.unique(h).size != h.size:
        raise ValueError("discretisation_band: two levels at one spacing")
    order = np.argsort(h)
    h, f = h[order], f[order]
    finest = f[0]
    free = _best([_free_fit(h, f, weighted) for weighted in (False, True)])
    trusted_order = P_MIN <= free.order  # faster than P_MAX: the first-order fits' larger error, still trusted
    if P_MIN <= free.order <= P_MAX:
        fit, how = free, f"observed order {free.order:.2f}"
    else:
        fixed = [_best([_fixed_fit(kind, h, f, weighted) for weighted in (False, True)]) for kind in FALLBACK]
        fit = _best(fixed)
        how = (f"observed order {free.order:.2f} outside [{P_MIN:g}, {P_MAX:g}]: the {fit.kind} fit, the closer "
               "of the first-order ones")
    eps = abs(finest - fit.fos_limit) if fit is free else max(abs(finest - each.fos_limit) for each in fixed)
    data_range = float(np.ptp(f)) / (f.size - 1)
    scatter = max(fit.sigma, measured_scatter, resolution)
    distance = abs(finest - float(fit.at(h[0])))
    noisy = scatter >= data_range
    safety = TRUSTED_SAFETY_FACTOR if trusted_order and not noisy else UNTRUSTED_SAFETY_FACTOR
    if noisy:
        uncertainty = 3.0 * scatter / max(data_range, 1e-300) * (eps + scatter + distance)
        why = (f"not to be trusted: the levels differ by {data_range:.4f} per level, no more than their scatter "
               f"{scatter:.4f}; refine further or search each level tighter")
    else:
        uncertainty = safety * eps + scatter + distance
        why = ("trusted" if safety == TRUSTED_SAFETY_FACTOR else
               "not to be trusted: the observed order is not that of the method; take more or finer levels")
    reason = (f"{how}; FOS at h -> 0 {fit.fos_limit:.4f}, error of the finest level {eps:.4f}, scatter {scatter:.4f} "
              f"(fit {fit.sigma:.4f}, measured {measured_scatter:.4f}), Fs = {safety:g}: {why}")
    return DiscretisationBand(fit.fos_limit, uncertainty, fit, eps, scatter, data_range, safety,
                              safety == TRUSTED_SAFETY_FACTOR, reason)
