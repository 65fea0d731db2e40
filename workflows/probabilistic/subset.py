"""Subset simulation (Au & Beck 2001) on the FOS: pf = P(FOS < factor) as a product of conditional
probabilities, each about p0, estimated level by level with Markov chains.

Level 0 is Monte Carlo: N points ``u`` standard normal (the variables' standard normal space).  Each
level sorts its N FOS values; if fewer than ``N p0`` lie below the factor, its threshold is

    b_k = (F_(N p0) + F_(N p0 + 1)) / 2       (the p0-quantile: the N p0 lowest lie below it),

and the N p0 lowest points seed as many Markov chains of ``1 / p0`` states each (the seed the first),
which make the next level's N points, all with FOS < b_k.  A chain moves by conditional sampling
(Papaioannou et al. 2015), reversible with respect to the standard normal law of ``u``:

    candidate = rho u + sqrt(1 - rho^2) eps,   eps standard normal,   accepted if FOS(candidate) < b_k,

the state repeated otherwise; it needs no ratio of densities and works in any dimension: a random field's
standard normal vector xi (thousands of numbers, the field a linear map of it) moves all at once the same
way, written as the weighted sum of the streams' vectors it is made of (:func:`moved_terms`).  Once a
level has at least ``N p0`` points below the factor (or the levels run out) it is the last, ``m``:

    pf = p0^m P_m,     P_m = #(FOS < factor) / N.

The estimator's coefficient of variation (Au & Beck 2001, eqs. 25-29): level k's
``delta_k^2 = (1 - p_k) / (N p_k) (1 + gamma_k)``, ``gamma_k = 2 sum_{l=1}^{Ns-1} (1 - l / Ns) rho_k(l)``
from the correlation ``rho_k(l)`` of the indicator ``FOS < b_k`` (or < factor at the last level) along the
chains of that level, lag l, ``Ns = 1 / p0`` states per chain (gamma = 0 at level 0, Monte Carlo); the
levels taken as uncorrelated, ``delta^2 = sum delta_k^2`` (a lower bound where they correlate).
"""

from __future__ import annotations

import math

import numpy as np

PROPOSAL_CORRELATION = 0.8
"""rho of the conditional sampling (module doc): the candidate keeps 0.8 of the state (Papaioannou et al.
recommend 0.8 for a fixed value; a larger rho accepts more and moves less)."""


def seeds_and_threshold(fos: np.ndarray, p0: float, factor: float) -> tuple[np.ndarray, float, bool]:
    """(the indices of the N p0 lowest FOS, in order, the threshold b_k, whether this level is the last:
    at least N p0 of its FOS lie below ``factor``) (module doc)."""
    fos = np.asarray(fos, float)
    n_seeds = int(round(p0 * fos.size))
    order = np.argsort(fos, kind="stable")
    if np.count_nonzero(fos < factor) >= n_seeds:
        return order[:n_seeds], factor, True
    return order[:n_seeds], 0.5 * (fos[order[n_seeds - 1]] + fos[order[n_seeds]]), False


def candidate(u: np.ndarray, eps: np.ndarray, rho: float = PROPOSAL_CORRELATION) -> np.ndarray:
    """rho u + sqrt(1 - rho^2) eps (module doc)."""
    return rho * np.asarray(u, float) + math.sqrt(1.0 - rho * rho) * np.asarray(eps, float)


def moved_terms(terms: tuple, own: int, rho: float = PROPOSAL_CORRELATION) -> tuple:
    """A random field's candidate as its standard normal vector's terms (realisation, weight): rho times the
    state's, and sqrt(1 - rho^2) times the vector of the candidate's own stream, realisation ``own`` (the
    candidate of the module doc, in the fields' space; ``random_field.combination``)."""
    return tuple((realisation, rho * weight) for realisation, weight in terms) + ((own, math.sqrt(1.0 - rho * rho)),)


GUARD_MARGIN_Z = 2.5
"""How many standard errors of the seeds' quantile a guard keeps above p0 (:func:`guard_quantile`): one level in
about 160 finds fewer than ``N p0 + 1`` samples below its guard, and searches those above it again."""


def guard_quantile(n_seeds: int, p0: float, z: float = GUARD_MARGIN_Z) -> float:
    """The quantile q of a level's ``n_seeds`` seeds' FOS at which its candidates' guard lies: the least q (on a
    0.01 grid) with ``q - z sqrt(q (1 - q) / n_seeds) >= p0``.  The seeds sample the level's FOS law (below the
    last threshold), so about a share q of the level lies below the guard, the standard error of that share about
    ``sqrt(q (1 - q) / n_seeds)``; the next threshold, the level's p0-quantile, then lies below it (1 at most: no
    guard)."""
    for q in np.arange(p0, 1.0, 0.01):
        if q - z * math.sqrt(q * (1.0 - q) / max(n_seeds, 1)) >= p0:
            return float(round(q, 2))
    return 1.0


def chain_gamma(indicator: np.ndarray) -> float:
    """gamma of a level from its chains' indicators (chains, states): Au & Beck's eq. 27-29 (module doc)."""
    indicator = np.asarray(indicator, float)
    n_chains, states = indicator.shape
    p = indicator.mean()
    variance = p * (1.0 - p)
    if variance <= 0.0 or states < 2:
        return 0.0
    gamma = 0.0
    for lag in range(1, states):
        covariance = (indicator[:, : states - lag] * indicator[:, lag:]).mean() - p * p
        gamma += 2.0 * (1.0 - lag / states) * covariance / variance
    return max(gamma, 0.0)


def level_cov(p: float, n: int, gamma: float) -> float:
    """delta_k = sqrt((1 - p) / (N p) (1 + gamma)); infinite where nothing of the level lies below."""
    return math.sqrt((1.0 - p) / (n * p) * (1.0 + gamma)) if p > 0.0 else math.inf


def estimate(p0: float, last_fraction: float, levels: int) -> float:
    """pf = p0^m P_m for a last level m = ``levels - 1`` (module doc)."""
    return p0 ** (levels - 1) * last_fraction


def interval(pf: float, cov: float, z: float = 1.96) -> tuple[float, float]:
    """An approximate 95% interval of pf from its coefficient of variation, lognormal about pf:
    pf exp(-+ z sqrt(ln(1 + cov^2)))."""
    if not (pf > 0.0 and math.isfinite(cov)):
        return 0.0, math.nan
    s = math.sqrt(math.log1p(cov * cov))
    return pf * math.exp(-z * s), pf * math.exp(z * s)


def pf_below(p0: float, level_fos: list, thresholds: list, value: float, known_below: list | None = None) -> float:
    """P(FOS < value) from the deepest level whose samples hold it: level k's samples are conditional on
    FOS < b_k-1 (level 0's on nothing), so for value <= b_k-1, P = p0^k #(F_k < value) / N (``level_fos``:
    each level's samples' FOS; ``thresholds``: b_0, b_1, ... of the levels but the last); a level holds only
    values up to its ``known_below`` (its FOS above that are known only to lie above it), NaN where none does."""
    for k in range(len(level_fos) - 1, -1, -1):
        if known_below is not None and value > known_below[k]:
            continue
        if k == 0 or value <= thresholds[k - 1]:
            return p0**k * float(np.mean(np.asarray(level_fos[k], float) < value))
    return math.nan
