"""The statistics of a probabilistic study: the probability of failure and its confidence
interval, and the reliability index of the factors of safety.

- pf = n_failed / n with the exact (Clopper-Pearson) 95% interval
  [B^-1(a/2; k, n - k + 1), B^-1(1 - a/2; k + 1, n - k)], B the beta distribution, which holds
  its coverage at the small pf of slopes where the normal approximation does not;
- the reliability index as Slide2 reports it: for normal F, beta = (mu_F - 1) / sigma_F; for
  lognormal F, beta = ln(mu_F / sqrt(1 + V_F^2)) / sqrt(ln(1 + V_F^2)), V_F = sigma_F / mu_F.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from workflows.distributions import NORMAL, Distribution

CONFIDENCE = 0.95


def failure_probability(n_failed: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """(pf, low, high): the fraction failed and its exact (Clopper-Pearson) interval."""
    if n <= 0 or not 0 <= n_failed <= n:
        raise ValueError(f"{n_failed} failed of {n} realisations")
    alpha = 1.0 - confidence
    low = 0.0 if n_failed == 0 else float(stats.beta.ppf(alpha / 2, n_failed, n - n_failed + 1))
    high = 1.0 if n_failed == n else float(stats.beta.ppf(1 - alpha / 2, n_failed + 1, n - n_failed))
    return n_failed / n, low, high


def reliability_index(fos, distribution: Distribution = NORMAL) -> float:
    """beta of the sample of factors of safety ``fos`` taken as of ``distribution`` (module doc;
    ``Distribution.reliability_index``)."""
    fos = np.asarray(fos, float)
    return distribution.reliability_index(float(fos.mean()), float(fos.std(ddof=1)))


def lognormal_strength_pf(mean_strength: float, cov: float, fos_at_mean: float) -> float:
    """pf of a slope whose FOS is proportional to one lognormal strength (phi = 0, no spatial
    variation): it fails where cu < cu_crit = mean / F_det, pf = Phi((ln cu_crit - mu_ln) / sigma_ln)."""
    sigma2 = math.log1p(cov * cov)
    mu_ln = math.log(mean_strength) - 0.5 * sigma2
    return float(stats.norm.cdf((math.log(mean_strength / fos_at_mean) - mu_ln) / math.sqrt(sigma2)))
