"""Random fields whose scale of fluctuation no circulant embedding holds (``workflows.random_field.expansion``):
the Karhunen-Loeve expansion's cell averages against their target statistics (mean, the cell variance
against Vanmarcke's variance function, the correlogram against the covariance of cell averages), and
the single-variable limit beyond a multiple of the section."""

from __future__ import annotations

import numpy as np
import pytest

from workflows.random_field.correlation import GAUSSIAN, MARKOV
from workflows.random_field.embedding import EmbeddingError, ParticleField, cell_covariance, variance_function
from workflows.random_field.expansion import (
    SINGLE_VARIABLE_MULTIPLE,
    ExpandedField,
    SingleValueField,
    single_variable_limit,
)
from workflows.random_field.values import particle_field

SPACING_M = 0.5
X, Y = (a.ravel() for a in np.meshgrid(np.arange(0.0, 12.0, SPACING_M), np.arange(0.0, 4.0, SPACING_M),
                                       indexing="ij"))
DRAWS = 10000  # complex draws: 20,000 fields


def _fields(field, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.array([values for _ in range(DRAWS) for values in field.draw(rng)])


@pytest.mark.parametrize("model, theta_m", [(MARKOV, 20.0), (MARKOV, 40.0), (GAUSSIAN, 20.0)])
def test_the_expansion_serves_where_no_embedding_holds_and_keeps_the_cells_covariance(model, theta_m):
    """theta 20-40 m on a 12 m by 4 m lattice of 0.5 m, where the embedding fails: the expansion's
    covariance of every particle pair against C_A (the covariance of two cells' averages, by quadrature)
    within 0.01 of the variance, and each particle's variance within 1% of gamma(h, h)."""
    with pytest.raises(EmbeddingError):
        ParticleField(model, theta_m, theta_m, X, Y, SPACING_M)
    field = particle_field(model, theta_m, theta_m, np.column_stack([X, Y]), np.full(X.size, SPACING_M))
    assert isinstance(field, ExpandedField)
    gamma = variance_function(model, SPACING_M, SPACING_M, theta_m, theta_m)
    assert field.variance_kept.min() > 0.99 and field.variance_kept.max() < 1.0 + 1e-6
    implied = field.modes @ field.modes.T
    lags = np.arange(0.0, 12.0, SPACING_M)
    exact = cell_covariance(model, SPACING_M, lags, np.arange(0.0, 4.0, SPACING_M), theta_m, theta_m)
    ix, iy = np.rint(X / SPACING_M).astype(int), np.rint(Y / SPACING_M).astype(int)
    target = exact[np.abs(ix[:, None] - ix[None, :]), np.abs(iy[:, None] - iy[None, :])]
    assert np.abs(implied - target).max() < 0.01
    assert np.diag(implied) == pytest.approx(np.full(X.size, gamma), rel=0.01)


@pytest.mark.parametrize("model, theta_m", [(MARKOV, 20.0), (GAUSSIAN, 20.0)])
def test_the_expansions_draws_have_zero_mean_the_cell_variance_and_the_correlogram(model, theta_m):
    """20,000 draws: the mean within 0.03 (the field's average has a standard error near 0.007 of its
    own correlation), the variance of each particle gamma(h, h) within 3%, and the ensemble correlation of
    particles 1, 3 and 6 m apart along x and 1 and 3 m along y against C_A(tau) / C_A(0) within 0.02."""
    field = particle_field(model, theta_m, theta_m, np.column_stack([X, Y]), np.full(X.size, SPACING_M))
    values = _fields(field)
    gamma = variance_function(model, SPACING_M, SPACING_M, theta_m, theta_m)
    assert abs(values.mean()) < 0.03
    assert values.var(axis=0).mean() == pytest.approx(gamma, rel=0.03)
    grid = values.reshape(len(values), 24, 8) / np.sqrt(gamma)
    lags_x, lags_y = (1.0, 3.0, 6.0), (1.0, 3.0)
    exact = cell_covariance(model, SPACING_M, [0.0, *lags_x], [0.0, *lags_y], theta_m, theta_m)
    for k, lag in enumerate(lags_x, start=1):
        n = int(round(lag / SPACING_M))
        measured = (grid[:, :-n, :] * grid[:, n:, :]).mean()
        assert measured == pytest.approx(exact[k, 0] / exact[0, 0], abs=0.02), lag
    for k, lag in enumerate(lags_y, start=1):
        n = int(round(lag / SPACING_M))
        measured = (grid[:, :, :-n] * grid[:, :, n:]).mean()
        assert measured == pytest.approx(exact[0, k] / exact[0, 0], abs=0.02), lag


def test_a_graded_cloud_averages_each_particle_over_its_own_cell():
    """Two spacings side by side, theta 40 m: each particle's implied variance is gamma of its own cell
    within 1%."""
    coarse_x, coarse_y = (a.ravel() for a in np.meshgrid(np.arange(13.0, 20.0, 1.0), np.arange(0.0, 4.0, 1.0),
                                                         indexing="ij"))
    xy = np.column_stack([np.concatenate([X, coarse_x]), np.concatenate([Y, coarse_y])])
    spacing = np.concatenate([np.full(X.size, SPACING_M), np.full(coarse_x.size, 1.0)])
    field = particle_field(MARKOV, 40.0, 40.0, xy, spacing)
    assert isinstance(field, ExpandedField)
    variance = np.einsum("ij,ij->i", field.modes, field.modes)
    for h in (SPACING_M, 1.0):
        assert variance[spacing == h] == pytest.approx(np.full((spacing == h).sum(),
                                                               variance_function(MARKOV, h, h, 40.0, 40.0)),
                                                       rel=0.01)


def test_beyond_the_stated_multiple_of_the_section_the_field_is_one_value_per_realisation():
    """A scale of fluctuation over SINGLE_VARIABLE_MULTIPLE times the section: one standard normal value at
    every particle (mean 0, variance 1 over 20,000 draws); just below it, still a field."""
    extent = (12.0, 4.0)  # the cells' bounding box
    limit_m = SINGLE_VARIABLE_MULTIPLE * np.hypot(*extent)
    assert single_variable_limit(1.01 * limit_m, 1.01 * limit_m, *extent)
    assert not single_variable_limit(0.99 * limit_m, 0.99 * limit_m, *extent)
    field = particle_field(MARKOV, 1.01 * limit_m, 1.01 * limit_m, np.column_stack([X, Y]),
                           np.full(X.size, SPACING_M))
    assert isinstance(field, SingleValueField)
    values = _fields(field)
    assert (np.ptp(values, axis=1) == 0.0).all()
    assert abs(values.mean()) < 0.03 and values[:, 0].var() == pytest.approx(1.0, rel=0.03)
    assert not isinstance(particle_field(MARKOV, 0.99 * limit_m, 0.99 * limit_m, np.column_stack([X, Y]),
                                         np.full(X.size, SPACING_M)), SingleValueField)
