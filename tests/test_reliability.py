"""pf and its interval, the reliability index, and the closed-form pf of a slope whose FOS is
proportional to one lognormal strength, against Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from workflows.distributions import LOGNORMAL
from workflows.probabilistic.reliability import failure_probability, lognormal_strength_pf, reliability_index
from workflows.probabilistic.sampling import Marginal, Sampler


def test_the_exact_interval_covers_the_true_pf_at_least_95_percent_of_the_time():
    rng = np.random.default_rng(1)
    for pf_true, n in ((0.02, 200), (0.3, 100)):
        failed = rng.binomial(n, pf_true, size=4000)
        covered = [low <= pf_true <= high for _, low, high in (failure_probability(int(k), n) for k in failed)]
        assert np.mean(covered) >= 0.95


def test_no_failure_and_all_failed_have_their_one_sided_ends():
    assert failure_probability(0, 100)[1:] == (0.0, pytest.approx(1 - 0.025 ** (1 / 100)))
    assert failure_probability(100, 100)[2] == 1.0
    with pytest.raises(ValueError):
        failure_probability(5, 3)


def test_reliability_index_of_normal_and_lognormal_factors():
    fos = stats.norm(1.3, 0.15).rvs(size=200000, random_state=3)
    assert reliability_index(fos) == pytest.approx(2.0, rel=0.01)
    lognormal = Marginal(LOGNORMAL, 1.3, 0.15)
    fos = lognormal.from_normal(np.random.default_rng(4).standard_normal(200000))
    beta = reliability_index(fos, LOGNORMAL)
    assert stats.norm.cdf(-beta) == pytest.approx(float(np.mean(fos < 1.0)), rel=0.05)


@pytest.mark.parametrize("cov", [0.25, 0.5, 1.0])
def test_monte_carlo_pf_of_a_strength_proportional_fos_lies_in_its_interval_of_the_closed_form(cov):
    """F = F_det cu / mean(cu): 2,000 sampled cu give a pf whose 95% interval holds the closed form."""
    f_det = 1.3
    cu = Sampler([Marginal(LOGNORMAL, 20e3, cov * 20e3)]).monte_carlo(17, range(2000))[:, 0]
    failed = int(np.sum(f_det * cu / 20e3 < 1.0))
    _, low, high = failure_probability(failed, 2000)
    assert low <= lognormal_strength_pf(20e3, cov, f_det) <= high
    assert math.isclose(lognormal_strength_pf(20e3, 1e-9, f_det), 0.0, abs_tol=1e-12)
