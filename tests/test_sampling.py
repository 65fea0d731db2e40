"""Random variables: marginals, correlation honoured in the samples (Nataf), Monte Carlo
realisations that do not depend on the count, and Latin hypercubes that keep their strata."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from workflows.distributions import LOGNORMAL, NORMAL, TRUNCATED_NORMAL, UNIFORM
from workflows.probabilistic.sampling import Marginal, Sampler, normal_correlation

COHESION = Marginal(LOGNORMAL, 10e3, 3e3)
FRICTION = Marginal(NORMAL, 30.0, 3.0)


def test_a_monte_carlo_realisation_is_the_same_whatever_the_count_and_order():
    sampler = Sampler([COHESION, FRICTION], np.array([[1.0, -0.5], [-0.5, 1.0]]))
    many = sampler.monte_carlo(2024, range(1000))
    assert np.array_equal(sampler.monte_carlo(2024, [737]), many[737:738])
    assert np.array_equal(sampler.monte_carlo(2024, [900, 3])[::-1], many[[3, 900]])
    assert not np.array_equal(sampler.monte_carlo(2025, [3]), many[3:4])


@pytest.mark.parametrize("marginal", [COHESION, FRICTION, Marginal(UNIFORM, 0.0, 0.0, low=20.0, high=40.0),
                                      Marginal(TRUNCATED_NORMAL, 30.0, 6.0, low=20.0, high=35.0)])
def test_samples_have_the_distributions_mean_and_std(marginal):
    values = Sampler([marginal]).monte_carlo(1, range(20000))[:, 0]
    frozen = marginal.frozen()
    assert values.mean() == pytest.approx(frozen.mean(), rel=0.01)
    assert values.std() == pytest.approx(frozen.std(), rel=0.03)
    assert marginal.low <= values.min() and values.max() <= marginal.high
    if marginal.distribution in (NORMAL, LOGNORMAL):
        assert frozen.mean() == pytest.approx(marginal.mean) and frozen.std() == pytest.approx(marginal.std)


@pytest.mark.parametrize("a, b, rho", [(COHESION, FRICTION, -0.5), (COHESION, Marginal(LOGNORMAL, 5.0, 4.0), 0.6),
                                       (Marginal(UNIFORM, 0.0, 0.0, low=0.0, high=1.0), FRICTION, 0.7)])
def test_the_samples_correlation_is_the_one_asked_for(a, b, rho):
    """20,000 realisations: Pearson correlation within 0.02 of rho (standard error below 0.01),
    where the copula's normals need another (-0.511, 0.652, 0.716)."""
    sampler = Sampler([a, b], np.array([[1.0, rho], [rho, 1.0]]))
    values = sampler.monte_carlo(9, range(20000))
    assert np.corrcoef(values, rowvar=False)[0, 1] == pytest.approx(rho, abs=0.02)
    assert sampler.normal[0, 1] != pytest.approx(rho, abs=1e-3)


@pytest.mark.parametrize("spread", [1e-12, 1e-8, 1e-4])
def test_a_variable_of_tiny_spread_is_correlated_as_the_normal_it_nearly_is(spread):
    """A lognormal cohesion of mean 10 kPa and std ``spread`` Pa, correlated -0.5 with a truncated
    normal friction angle: the copula's rho_z is the one a normal cohesion needs (a lognormal of COV
    1e-12 is linear in its normal), with no warning.  Measured as x - E[x] over scipy's std, it was
    rounding noise over 0: 5.8e-11 for 1e-8 Pa (no correlation at all), 'out of reach (from -inf to
    -inf)' for 1e-12 Pa, each with a RuntimeWarning on stderr (found by the study-file fuzzer)."""
    friction = Marginal(TRUNCATED_NORMAL, 20.0, 2.0, low=15.0, high=25.0)
    cohesion, as_normal = Marginal(LOGNORMAL, 10e3, spread), Marginal(NORMAL, 10e3, 1.0)
    assert normal_correlation(cohesion, friction, -0.5) == pytest.approx(
        normal_correlation(as_normal, friction, -0.5), abs=1e-9)
    assert normal_correlation(friction, cohesion, -0.5) == pytest.approx(
        normal_correlation(friction, as_normal, -0.5), abs=1e-9)


@pytest.mark.parametrize("low, high", [(15.0, math.inf), (-math.inf, 25.0), (-math.inf, math.inf)])
def test_a_normal_truncated_on_one_side_is_correlated_as_one_with_a_far_bound(low, high):
    """A friction angle truncated below only (high = inf, as a study gives it by leaving high out):
    the quadrature's far nodes read Phi(z) = 1, whose quantile is the infinite bound (NaN: "The
    function value at x=0.0 is NaN", blamed on probabilistic.correlation, with a RuntimeWarning;
    found by the study-file fuzzer), or a far bound (a rho_z 0.002 off).  Either order of the two
    variables gives the same rho_z; untruncated, the normal's."""
    friction = Marginal(TRUNCATED_NORMAL, 20.0, 2.0, low=low, high=high)
    far = Marginal(TRUNCATED_NORMAL, 20.0, 2.0, low=max(low, -1e6), high=min(high, 1e6))
    rho_z = normal_correlation(COHESION, friction, -0.5)
    assert rho_z == pytest.approx(normal_correlation(COHESION, far, -0.5), abs=1e-9)
    assert rho_z == pytest.approx(normal_correlation(friction, COHESION, -0.5), abs=1e-6)
    if math.isinf(low) and math.isinf(high):
        assert rho_z == pytest.approx(normal_correlation(COHESION, Marginal(NORMAL, 20.0, 2.0), -0.5), abs=1e-9)


def test_the_lognormal_closed_form_agrees_with_the_quadrature():
    a, b = COHESION, Marginal(LOGNORMAL, 5.0, 4.0)
    closed = normal_correlation(a, b, 0.6)
    # E[(x1 - m1)(x2 - m2)] / (s1 s2) of the copula at that rho_z, by a finer quadrature
    nodes, weights = np.polynomial.hermite_e.hermegauss(60)
    weights = weights / weights.sum()
    u, v = np.meshgrid(nodes, nodes, indexing="ij")
    z2 = closed * u + math.sqrt(1 - closed**2) * v
    xa, xb = a.from_normal(u), b.from_normal(z2)
    achieved = (np.outer(weights, weights) * (xa - a.mean) * (xb - b.mean)).sum() / (a.std * b.std)
    assert achieved == pytest.approx(0.6, abs=2e-3)


def test_a_latin_hypercube_puts_one_value_in_each_stratum_and_has_the_correlation():
    sampler = Sampler([COHESION, FRICTION], np.array([[1.0, -0.5], [-0.5, 1.0]]))
    values = sampler.latin_hypercube(5, 200)
    for j, marginal in enumerate(sampler.marginals):
        strata = np.floor(marginal.frozen().cdf(values[:, j]) * 200).astype(int)
        assert sorted(strata) == list(range(200))
    assert stats.spearmanr(values[:, 0], values[:, 1]).statistic == pytest.approx(-0.5, abs=0.05)
    assert np.array_equal(sampler.latin_hypercube(5, 200), values)


def test_an_impossible_correlation_is_an_error():
    with pytest.raises(ValueError, match="positive definite"):
        Sampler([FRICTION] * 3, np.array([[1.0, 0.9, -0.9], [0.9, 1.0, 0.9], [-0.9, 0.9, 1.0]]))
    with pytest.raises(ValueError, match="symmetric"):
        Sampler([FRICTION, FRICTION], np.array([[1.0, 0.5], [0.4, 1.0]]))
    with pytest.raises(ValueError, match="out of reach"):
        normal_correlation(Marginal(LOGNORMAL, 1.0, 3.0), Marginal(LOGNORMAL, 1.0, 0.1), -0.99)
