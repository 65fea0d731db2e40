"""Random fields against their target statistics: mean, variance, the correlation function along
both axes (anisotropy), the variance reduction of cell averages (Vanmarcke's variance function),
the lognormal transform, and reproducibility from the seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from workflows.distributions import lognormal_parameters
from workflows.random_field.correlation import GAUSSIAN, MARKOV
from workflows.random_field.embedding import (
    CELL_QUADRATURE_POINTS,
    GridField,
    ParticleField,
    cell_correlation,
    cell_covariance,
    correlation,
    variance_function,
)

DRAWS = 1500  # complex draws: 3,000 fields


def _fields(grid: GridField, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.array([field for _ in range(DRAWS) for field in grid.draw(rng)])


@pytest.mark.parametrize("model", [MARKOV, GAUSSIAN])
def test_grid_fields_have_zero_mean_unit_variance_and_the_model_correlation_along_each_axis(model):
    """theta_x = 4 m, theta_y = 1 m on a 0.25 m grid: the ensemble correlation at lags 0.25-2 m
    along x and 0.25-0.5 m along y within 0.03 of rho (a standard error about 0.01)."""
    theta_x, theta_y, step = 4.0, 1.0, 0.25
    grid = GridField.build(model, theta_x, theta_y, 24, 12, step, step)
    fields = _fields(grid)
    assert abs(fields.mean()) < 0.02
    assert fields.var(axis=0).mean() == pytest.approx(1.0, abs=0.03)
    for lag_points in (1, 2, 4, 8):
        measured = (fields[:, :-lag_points, :] * fields[:, lag_points:, :]).mean()
        assert measured == pytest.approx(float(correlation(model, lag_points * step, 0.0, theta_x, theta_y)),
                                         abs=0.03)
    for lag_points in (1, 2):
        measured = (fields[:, :, :-lag_points] * fields[:, :, lag_points:]).mean()
        assert measured == pytest.approx(float(correlation(model, 0.0, lag_points * step, theta_x, theta_y)),
                                         abs=0.03)


def test_the_two_fields_of_one_draw_are_independent():
    grid = GridField.build(MARKOV, 2.0, 2.0, 20, 20, 0.25, 0.25)
    rng = np.random.default_rng(3)
    pairs = [grid.draw(rng) for _ in range(DRAWS)]
    cross = np.mean([(a * b).mean() for a, b in pairs])
    assert abs(cross) < 0.02


def test_the_markov_scale_of_fluctuation_is_twice_the_exponential_length():
    """rho = exp(-2 tau / theta): GSTools' exp(-r / l) with l = theta / 2, and the integral of rho
    over all lags is theta."""
    tau = np.linspace(0.0, 50.0, 200001)
    assert float(correlation(MARKOV, tau, 0.0, 3.0, 1.0)[1000]) == pytest.approx(math.exp(-tau[1000] / 1.5))
    for model in (MARKOV, GAUSSIAN):
        assert 2.0 * np.trapezoid(correlation(model, tau, 0.0, 3.0, 1.0), tau) == pytest.approx(3.0, rel=1e-4)


@pytest.mark.parametrize("model, theta_m", [(MARKOV, 1.0), (MARKOV, 4.0), (GAUSSIAN, 1.0)])
def test_cell_averages_have_the_variance_of_vanmarckes_variance_function(model, theta_m):
    """Particles on a 0.5 m lattice, each the average over its 0.5 m cell (drawn from the covariance of
    cell averages itself): the ensemble variance is gamma(0.5, 0.5) within 4% (a standard error about
    1.5%)."""
    x, y = np.meshgrid(np.arange(0.0, 6.0, 0.5), np.arange(0.0, 3.0, 0.5), indexing="ij")
    field = ParticleField(model, theta_m, theta_m, x.ravel(), y.ravel(), 0.5)
    rng = np.random.default_rng(11)
    values = np.array([value for _ in range(DRAWS) for value in field.draw(rng)])
    gamma = variance_function(model, 0.5, 0.5, theta_m, theta_m)
    assert gamma < 1.0
    assert values.var(axis=0).mean() == pytest.approx(gamma, rel=0.04)


def test_the_variance_function_falls_from_one_as_the_cell_grows_against_theta():
    values = [variance_function(MARKOV, t, t, 1.0, 1.0) for t in (1e-4, 0.5, 1.0, 4.0)]
    assert values[0] == pytest.approx(1.0, abs=1e-3)
    assert all(a > b for a, b in zip(values, values[1:]))


def test_a_lognormal_field_has_its_mean_and_cov():
    """exp(mu_ln + sigma_ln G) of point values: mean 20 kPa and COV 0.5 within 2% and 4%."""
    mu, sigma = lognormal_parameters(20e3, 0.5)
    grid = GridField.build(MARKOV, 1.0, 1.0, 16, 16, 0.25, 0.25)
    values = np.exp(mu + sigma * _fields(grid, seed=5))
    assert values.mean() == pytest.approx(20e3, rel=0.02)
    assert values.std() / values.mean() == pytest.approx(0.5, rel=0.04)


def test_the_same_seed_gives_the_same_field_and_another_seed_another():
    x, y = np.meshgrid(np.arange(0.0, 4.0, 0.5), np.arange(0.0, 2.0, 0.5), indexing="ij")
    field = ParticleField(MARKOV, 2.0, 1.0, x.ravel(), y.ravel(), 0.5)
    first = field.draw(np.random.default_rng(np.random.SeedSequence([42, 7])))
    again = field.draw(np.random.default_rng(np.random.SeedSequence([42, 7])))
    other = field.draw(np.random.default_rng(np.random.SeedSequence([42, 8])))
    assert np.array_equal(first[0], again[0]) and not np.allclose(first[0], other[0])


def test_a_correlation_no_embedding_holds_is_an_error_not_a_wrong_field():
    """A Gaussian correlation 10 times longer than a 4 m grid: a tenth of the embedding's eigenvalues
    are negative even at 8 times the grid (a field of nearly one value would be fine: theta = 400 m
    leaves 1e-4, within NEGATIVE_SHARE)."""
    with pytest.raises(ValueError, match="no nonnegative circulant embedding"):
        GridField.build(GAUSSIAN, 40.0, 40.0, 16, 16, 0.25, 0.25)
    assert GridField.build(GAUSSIAN, 400.0, 400.0, 16, 16, 0.25, 0.25).sqrt_eigen.shape == (32, 32)


@pytest.mark.parametrize("model, theta_m", [(MARKOV, 0.5), (MARKOV, 1.0), (GAUSSIAN, 1.0)])
def test_the_covariance_of_cell_averages_at_lag_zero_is_the_variance_function(model, theta_m):
    """C_A(0) by the embedding's quadrature (CELL_QUADRATURE_POINTS) against gamma by 400 points: within
    2e-4 where the Markov model's kink at zero lag is sharpest against the cell (theta = h / 2)."""
    covariance = cell_covariance(model, 1.0, [0.0], [0.0], theta_m, theta_m, CELL_QUADRATURE_POINTS)[0, 0]
    assert covariance == pytest.approx(variance_function(model, 1.0, 1.0, theta_m, theta_m, points=400), rel=2e-4)


@pytest.mark.parametrize("model", [MARKOV, GAUSSIAN])
def test_particles_of_one_spacing_correlate_as_their_cells_averages_do(model):
    """A 0.5 m lattice, theta = 1 m: the ensemble correlation of particle pairs 0.5, 1 and 1.5 m apart
    along x and along y against cell_correlation, within 0.03 (a standard error about 0.01)."""
    x, y = np.meshgrid(np.arange(0.0, 6.0, 0.5), np.arange(0.0, 4.0, 0.5), indexing="ij")
    field = ParticleField(model, 1.0, 1.0, x.ravel(), y.ravel(), 0.5)
    rng = np.random.default_rng(5)
    values = np.array([value for _ in range(DRAWS) for value in field.draw(rng)]).reshape(-1, *x.shape)
    values /= math.sqrt(variance_function(model, 0.5, 0.5, 1.0, 1.0))
    for lag in (1, 2, 3):
        target = cell_correlation(model, 0.5, 0.5 * lag, 0.0, 1.0, 1.0)
        assert (values[:, :-lag, :] * values[:, lag:, :]).mean() == pytest.approx(target, abs=0.03)
        assert (values[:, :, :-lag] * values[:, :, lag:]).mean() == pytest.approx(target, abs=0.03)


def test_a_graded_cloud_averages_each_particle_over_its_own_cell():
    """Two spacings (0.5 m and 1 m lattices side by side): each particle's variance is gamma of its own
    cell, within 5% (the box average of a grid h / 4 fine)."""
    fine_x, fine_y = np.meshgrid(np.arange(0.0, 3.0, 0.5), np.arange(0.0, 3.0, 0.5), indexing="ij")
    coarse_x, coarse_y = np.meshgrid(np.arange(4.0, 8.0, 1.0), np.arange(0.0, 3.0, 1.0), indexing="ij")
    x = np.concatenate([fine_x.ravel(), coarse_x.ravel()])
    y = np.concatenate([fine_y.ravel(), coarse_y.ravel()])
    spacing = np.concatenate([np.full(fine_x.size, 0.5), np.full(coarse_x.size, 1.0)])
    field = ParticleField(MARKOV, 1.0, 1.0, x, y, spacing)
    assert field.grid.cell_m is None  # the point field, box-averaged per cell
    rng = np.random.default_rng(13)
    variance = np.array([value for _ in range(DRAWS) for value in field.draw(rng)]).var(axis=0)
    for h in (0.5, 1.0):
        assert variance[spacing == h].mean() == pytest.approx(variance_function(MARKOV, h, h, 1.0, 1.0), rel=0.05)
