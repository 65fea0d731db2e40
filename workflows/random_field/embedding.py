"""Stationary Gaussian random fields on a grid by circulant embedding, and their local averages.

A field ``G`` of zero mean, unit variance and correlation ``rho(tau_x, tau_y)`` is sampled
exactly on a regular grid (Dietrich & Newsam 1997): the grid's covariance matrix, embedded in
a periodic grid at least twice as large, is block circulant, so the FFT diagonalises it,

    C = F* diag(lambda) F / N,      lambda = FFT(rho on the periodic grid),
    G = Re and Im of FFT(sqrt(lambda / N) (Z1 + i Z2)),   Z1, Z2 standard normal,

one complex draw giving two independent fields.  Exact where every ``lambda >= 0``.  Negative
eigenvalues are set to zero, which changes every covariance of the grid by at most the share of
the negative ones, ``sum(|lambda_-|) / sum(lambda)``, times the variance (the change is
``F* diag(|lambda_-|) F / N``, whose entries are bounded by its trace over N); the embedding
grows from twice the grid until that share is at most :data:`NEGATIVE_SHARE`, and a correlation
no embedding up to :data:`MAX_EMBEDDING` times the grid reaches it with is an error
(:class:`EmbeddingError`), never a wrong field: a scale of fluctuation much longer than the grid, which
``workflows.random_field.expansion`` draws instead.

The correlation ``rho`` is that of a model of ``workflows.random_field.correlation`` (``markov``,
``gaussian``), a function of r = sqrt((tau_x / theta_x)^2 + (tau_y / theta_y)^2) with the scales of
fluctuation ``theta``; every function here takes the model object.

A particle's value is the average of the field over its smoothing cell, taken here as the
square of side ``h`` (its spacing) about it.  Its variance is the point variance times
Vanmarcke's variance function ``gamma(h, h)`` (:func:`variance_function`), the variance
reduction of RFEM (Griffiths & Fenton 2004) that a point sample would miss.  Two ways to
sample it (:class:`ParticleField`):

- a cloud of one spacing h (uniform, jittered or not): the cell averages ``A`` are themselves a
  stationary Gaussian field, of covariance (:func:`cell_covariance`)

      C_A(tau) = int int w(a) w(b) rho(tau_x + a, tau_y + b) da db,   w(a) = (h - |a|) / h^2 on [-h, h],

  sampled exactly by circulant embedding of ``C_A`` on a grid of step ``h / CELL_GRID``, each
  particle taking the value at the grid point nearest it (the lattice particles lie on it);
- a graded cloud (several spacings, whose averages of different cells no single stationary field
  holds): the point field on a grid ``GRID_PER_CELL`` times finer than the finest cell, each
  particle the box average of its own cell's grid points (a box filter).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from workflows.random_field.correlation import CorrelationModel

NEGATIVE_SHARE = 1e-3
"""Largest share of negative eigenvalues of an embedding (module doc): every covariance of the grid
within 1e-3 of the variance, far below what 1,000 realisations resolve (a standard error of 0.03)."""
MAX_EMBEDDING = 8
"""The periodic grid reaches at most this many times the grid in each direction."""
GRID_PER_CELL = 4
"""Grid points per finest particle spacing in each direction, for the box averages of a graded cloud."""
CELL_GRID = 2
"""Grid points per particle spacing in each direction where the cell averages are sampled exactly
(a cloud of one spacing): edge particles, off the lattice, sit within h / 4 of a grid point."""
CELL_QUADRATURE_POINTS = 12
"""Gauss-Legendre points on each half of a cell's side for :func:`cell_covariance` on the embedding:
C_A(0) within 2e-4 of gamma for the Markov model at theta / h = 1 (tests/test_random_field.py)."""


def correlation(model: CorrelationModel, tau_x_m, tau_y_m, theta_x_m: float, theta_y_m: float):
    """rho of the model (module doc) at the lags ``tau_x_m``, ``tau_y_m`` (arrays, m)."""
    return model.of_squared_lag((np.asarray(tau_x_m) / theta_x_m) ** 2 + (np.asarray(tau_y_m) / theta_y_m) ** 2)


class EmbeddingError(ValueError):
    """A correlation no circulant embedding up to :data:`MAX_EMBEDDING` times its grid holds (a scale of
    fluctuation too long for the grid: ``workflows.random_field.expansion`` draws it)."""


def embedding(model: CorrelationModel, theta_x_m: float, theta_y_m: float, nx: int, ny: int, dx_m: float, dy_m: float,
              cell_m: float | None = None) -> np.ndarray | None:
    """sqrt(lambda / N) of the smallest periodic grid, from twice the ``nx`` x ``ny`` grid up to
    :data:`MAX_EMBEDDING` times it, whose negative eigenvalues are at most :data:`NEGATIVE_SHARE` of
    their sum (module doc; :meth:`GridField.build`); None when none is."""
    from scipy import fft  # scipy.fft: only when a field is drawn

    for factor in range(2, MAX_EMBEDDING + 1):
        mx, my = fft.next_fast_len(factor * nx), fft.next_fast_len(factor * ny)
        ix, iy = np.arange(mx), np.arange(my)
        tau_x = np.minimum(ix, mx - ix) * dx_m  # the periodic (minimal-image) lag
        tau_y = np.minimum(iy, my - iy) * dy_m
        if cell_m is None:
            rho = correlation(model, tau_x[:, None], tau_y[None, :], theta_x_m, theta_y_m)
        else:  # C_A depends on |tau_x| and |tau_y|: computed once per distinct lag
            quarter = cell_covariance(model, cell_m, np.arange(mx // 2 + 1) * dx_m, np.arange(my // 2 + 1) * dy_m,
                                      theta_x_m, theta_y_m, CELL_QUADRATURE_POINTS)
            rho = quarter[np.minimum(ix, mx - ix)][:, np.minimum(iy, my - iy)]
        eigen = fft.fft2(rho).real
        if -eigen[eigen < 0.0].sum() <= NEGATIVE_SHARE * eigen.sum():
            return np.sqrt(np.maximum(eigen, 0.0) / (mx * my))
    return None


@dataclass(frozen=True)
class GridField:
    """The circulant embedding of one model on one grid: draws fields of it (module doc)."""

    model: CorrelationModel
    theta_x_m: float
    theta_y_m: float
    nx: int
    ny: int
    dx_m: float
    dy_m: float
    sqrt_eigen: np.ndarray  # sqrt(lambda / N) on the periodic grid (mx, my)
    cell_m: float | None = None  # the field of the averages over cell_m squares (None: point values)

    @classmethod
    @functools.lru_cache(maxsize=8)  # the realisations of a study on one worker share the embedding
    def build(cls, model: CorrelationModel, theta_x_m: float, theta_y_m: float, nx: int, ny: int, dx_m: float,
              dy_m: float, cell_m: float | None = None) -> GridField:
        """The embedding of an ``nx`` x ``ny`` grid of spacing ``dx_m``, ``dy_m`` for the point field,
        or with ``cell_m`` for the field of its averages over squares of that side (covariance
        :func:`cell_covariance`); :class:`EmbeddingError` when no embedding up to :data:`MAX_EMBEDDING`
        times the grid keeps its negative eigenvalues within :data:`NEGATIVE_SHARE` (kept for the next
        call with the same arguments: a field draws from it, never changes it)."""
        sqrt_eigen = embedding(model, theta_x_m, theta_y_m, nx, ny, dx_m, dy_m, cell_m)
        if sqrt_eigen is None:
            raise EmbeddingError(f"the {model} correlation with theta = ({theta_x_m:g}, {theta_y_m:g}) m has no "
                                 f"nonnegative circulant embedding up to {MAX_EMBEDDING} times the grid (negative "
                                 f"eigenvalues above {NEGATIVE_SHARE:g} of their sum)")
        sqrt_eigen.setflags(write=False)  # shared by the cache
        return cls(model, theta_x_m, theta_y_m, nx, ny, dx_m, dy_m, sqrt_eigen, cell_m)

    def standard_normals(self, rng: np.random.Generator) -> np.ndarray:
        """The standard normal vector xi of one draw: Z1 then Z2 of the periodic grid, raveled (what
        :meth:`draw` takes from ``rng``, in its order)."""
        return np.concatenate([rng.standard_normal(self.sqrt_eigen.shape).ravel(),
                               rng.standard_normal(self.sqrt_eigen.shape).ravel()])

    def field_of(self, xi: np.ndarray) -> np.ndarray:
        """The field of the standard normal vector ``xi`` (:meth:`standard_normals`), linear in it:
        Re FFT(sqrt(lambda / N) (Z1 + i Z2)) on the grid (module doc), the first field of :meth:`draw`."""
        from scipy import fft  # scipy.fft: only when a field is drawn

        size = self.sqrt_eigen.size
        z = (xi[:size] + 1j * xi[size:]).reshape(self.sqrt_eigen.shape)
        return fft.fft2(self.sqrt_eigen * z).real[: self.nx, : self.ny]

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Two independent fields of zero mean and unit variance on the grid, each (nx, ny)."""
        from scipy import fft  # scipy.fft: only when a field is drawn

        shape = self.sqrt_eigen.shape
        z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
        field = fft.fft2(self.sqrt_eigen * z)
        return field.real[: self.nx, : self.ny], field.imag[: self.nx, : self.ny]


def variance_function(model: CorrelationModel, length_x_m: float, length_y_m: float, theta_x_m: float, theta_y_m: float,
                      points: int = 64) -> float:
    """gamma(T_x, T_y): the variance of the average over a T_x x T_y rectangle over the point
    variance, gamma = 4 / (T_x T_y)^2 int_0^T_x int_0^T_y (T_x - a)(T_y - b) rho(a, b) da db
    (Vanmarcke 1983), by Gauss-Legendre quadrature."""
    nodes, weights = np.polynomial.legendre.leggauss(points)
    a = 0.5 * length_x_m * (nodes + 1.0)
    b = 0.5 * length_y_m * (nodes + 1.0)
    wa, wb = 0.5 * length_x_m * weights, 0.5 * length_y_m * weights
    rho = correlation(model, a[:, None], b[None, :], theta_x_m, theta_y_m)
    inner = ((length_x_m - a) * wa)[:, None] * ((length_y_m - b) * wb)[None, :] * rho
    return float(4.0 * inner.sum() / (length_x_m * length_y_m) ** 2)


def cell_covariance(model: CorrelationModel, cell_m: float, tau_x_m, tau_y_m, theta_x_m: float, theta_y_m: float,
                    points: int = 48) -> np.ndarray:
    """The covariance of the averages of a unit-variance field over two ``cell_m`` x ``cell_m`` squares
    whose centres lie (tau_x, tau_y) apart, on the grid of lags ``tau_x_m`` x ``tau_y_m`` (1-D arrays;
    a (len(tau_x), len(tau_y)) array):

        C_A = int int w(a) w(b) rho(tau_x + a, tau_y + b) da db,

    w(a) = (T - |a|) / T^2 on [-T, T] the density of the difference of two points of one side (so
    that C_A(0) = gamma(T, T), :func:`variance_function`), by Gauss-Legendre quadrature with
    ``points`` nodes on each half of [-T, T] (the kink of w at 0 between them)."""
    nodes, weights = np.polynomial.legendre.leggauss(points)
    half = 0.5 * cell_m * (nodes + 1.0)  # [0, T], used for both signs of a
    a = np.concatenate([-half, half])
    w = np.concatenate([weights, weights]) * 0.5 * cell_m * (cell_m - np.abs(a)) / cell_m**2
    tau_x_m, tau_y_m = np.atleast_1d(np.asarray(tau_x_m, float)), np.atleast_1d(np.asarray(tau_y_m, float))
    out = np.empty((tau_x_m.size, tau_y_m.size))
    by = (tau_y_m[:, None] + a[None, :])[:, None, :]  # (lags y, 1, nodes b)
    for i, tx in enumerate(tau_x_m):  # one x lag at a time: (lags y, nodes a, nodes b) values of rho
        rho = correlation(model, (tx + a)[None, :, None], by, theta_x_m, theta_y_m)
        out[i] = (rho @ w) @ w
    return out


def cell_correlation(model: CorrelationModel, cell_m: float, tau_x_m: float, tau_y_m: float, theta_x_m: float,
                     theta_y_m: float, points: int = 48) -> float:
    """The correlation of the averages of two ``cell_m`` x ``cell_m`` squares whose centres lie
    (tau_x, tau_y) apart: C_A(tau) / C_A(0) (:func:`cell_covariance`)."""
    covariance = cell_covariance(model, cell_m, [0.0, abs(tau_x_m)], [0.0, abs(tau_y_m)], theta_x_m, theta_y_m,
                                 points)
    return float(covariance[1, 1] / covariance[0, 0])


def cell_averages(grid_values: np.ndarray, cell_points: int) -> np.ndarray:
    """The average of ``grid_values`` over the ``cell_points`` x ``cell_points`` box about each
    grid point (a box filter; the box shrinks to the grid at its edges)."""
    from scipy import ndimage  # scipy.ndimage: only when a field is drawn

    return ndimage.uniform_filter(grid_values, size=cell_points, mode="nearest")


@dataclass(frozen=True)
class ParticleGrid:
    """The grid a :class:`ParticleField` draws on: over the particles' bounding box widened by their
    largest spacing, step h / CELL_GRID holding the cell averages of one spacing (``cell_m`` = h), or
    h_min / GRID_PER_CELL holding the point field of several (``cell_m`` None)."""

    step_m: float
    origin_m: tuple[float, float]
    nx: int
    ny: int
    cell_m: float | None

    @classmethod
    def of(cls, x_m, y_m, spacing_m) -> ParticleGrid:
        x_m, y_m = np.asarray(x_m, float), np.asarray(y_m, float)
        spacing = np.broadcast_to(np.asarray(spacing_m, float), x_m.shape)
        one_spacing = float(spacing.max()) <= float(spacing.min()) * (1.0 + 1e-9)
        step_m = float(spacing.min()) / (CELL_GRID if one_spacing else GRID_PER_CELL)
        origin = (float(x_m.min() - spacing.max()), float(y_m.min() - spacing.max()))
        nx = int(math.ceil((x_m.max() + spacing.max() - origin[0]) / step_m)) + 1
        ny = int(math.ceil((y_m.max() + spacing.max() - origin[1]) / step_m)) + 1
        return cls(step_m, origin, nx, ny, float(spacing.min()) if one_spacing else None)

    @property
    def extent_m(self) -> tuple[float, float]:
        return (self.nx - 1) * self.step_m, (self.ny - 1) * self.step_m


class ParticleField:
    """Standard Gaussian values of a field at particles: each the average over its cell (module doc).

    One spacing h: the grid of the cell averages, step ``h / CELL_GRID``, over the particles'
    bounding box; a particle takes the value at the grid point nearest it.  Several: the point
    field on a grid of step ``h_min / GRID_PER_CELL``; a particle takes the box average of side its
    own spacing about the grid point nearest it."""

    def __init__(self, model: CorrelationModel, theta_x_m: float, theta_y_m: float, x_m: np.ndarray, y_m: np.ndarray,
                 spacing_m: np.ndarray | float):
        grid = ParticleGrid.of(x_m, y_m, spacing_m)
        self.step_m = grid.step_m
        self.grid = GridField.build(model, theta_x_m, theta_y_m, grid.nx, grid.ny, grid.step_m, grid.step_m,
                                    grid.cell_m)
        self.ix = np.rint((np.asarray(x_m, float) - grid.origin_m[0]) / grid.step_m).astype(np.int64)
        self.iy = np.rint((np.asarray(y_m, float) - grid.origin_m[1]) / grid.step_m).astype(np.int64)
        spacing = np.broadcast_to(np.asarray(spacing_m, float), self.ix.shape)
        self.cell_points = np.maximum(np.rint(spacing / grid.step_m).astype(np.int64), 1)
        self.sizes = np.unique(self.cell_points)

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Two independent standard Gaussian fields at the particles, cell-averaged (module doc)."""
        first, second = self.grid.draw(rng)
        return self._at_particles(first), self._at_particles(second)

    def standard_normals(self, rng: np.random.Generator) -> np.ndarray:
        """The standard normal vector of one draw (``GridField.standard_normals``)."""
        return self.grid.standard_normals(rng)

    def field_of(self, xi: np.ndarray) -> np.ndarray:
        """The field at the particles of the standard normal vector ``xi``, linear in it: the first field
        :meth:`draw` gives from the ``rng`` that :meth:`standard_normals` turns into ``xi``."""
        return self._at_particles(self.grid.field_of(xi))

    def _at_particles(self, grid_values: np.ndarray) -> np.ndarray:
        if self.grid.cell_m is not None:  # the grid holds the cell averages
            return grid_values[self.ix, self.iy]
        out = np.empty(self.ix.shape)
        for size in self.sizes:
            mine = self.cell_points == size
            out[mine] = cell_averages(grid_values, int(size))[self.ix[mine], self.iy[mine]]
        return out
