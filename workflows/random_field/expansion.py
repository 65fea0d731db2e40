"""A random field of any scale of fluctuation at the particles: a Karhunen-Loeve expansion on a grid of
nodes extended to each particle's cell, or one value per realisation beyond a multiple of the section.

Circulant embedding (``workflows.random_field.embedding``) is exact, but a scale of fluctuation much
longer than the grid has no nonnegative embedding (theta 74 m on a 60 m section).  Such a field is
smooth over the section, and a few hundred modes hold it:

- the point field's covariance on a regular grid of nodes ``x_j`` (step about the particles' spacing,
  at most :data:`MAX_NODES` nodes) is decomposed, ``C_nn = V diag(lambda) V^T`` (the discrete
  Karhunen-Loeve expansion), modes of ``lambda`` below :data:`EIGEN_FLOOR` of the largest dropped;
- each particle's value is the average over its cell (the square of side ``h`` about it) of the
  Nystrom extension of the modes,

      A(x) = sum_k a_k(x) xi_k,   a_k(x) = c(x)^T v_k / sqrt(lambda_k),   xi_k standard normal,

  ``c_j(x)`` the covariance of the cell average about ``x`` with the point ``x_j`` (Gauss-Legendre,
  :data:`CELL_POINTS` per side).  This is the kriging of the nodes' field onto the cells: exact at the
  nodes, and a particle's variance ``sum_k a_k(x)^2`` falls short of its cell's ``gamma(h, h)``
  (Vanmarcke's variance function) by the variance between the nodes; that share kept is reported
  (:attr:`ExpandedField.variance_kept`), never hidden.

Beyond :data:`SINGLE_VARIABLE_MULTIPLE` times the section (``sqrt((L_x / theta_x)^2 + (L_y / theta_y)^2)``
below its inverse: any two points correlate above ``rho(1 / SINGLE_VARIABLE_MULTIPLE)``, 0.98 for the Markov
model) the field is the single-variable limit: one standard normal value for every particle
(:class:`SingleValueField`), with a note.
"""

from __future__ import annotations

import math

import numpy as np

from workflows.random_field.correlation import CorrelationModel
from workflows.random_field.embedding import correlation, variance_function

SINGLE_VARIABLE_MULTIPLE = 100.0
"""A field whose scales of fluctuation exceed this many times the section's extent (module doc) is one value
per realisation: the least correlation between two of its points is exp(-2 / 100) = 0.98 (Markov)."""
MAX_NODES = 2000
"""Most nodes of the expansion's grid (its eigen-decomposition takes about 2 s, once per process)."""
EIGEN_FLOOR = 1e-10
"""Modes whose eigenvalue is below this share of the largest are dropped (rounding, not variance)."""
CELL_POINTS = 3
"""Gauss-Legendre points on each side of a particle's cell for its average of the covariance."""
NODES_PER_THETA = 8
"""At least this many nodes per scale of fluctuation in each direction (a long field needs few)."""


def single_variable_limit(theta_x_m: float, theta_y_m: float, extent_x_m: float, extent_y_m: float) -> bool:
    """Whether the scales of fluctuation exceed :data:`SINGLE_VARIABLE_MULTIPLE` times the section of extent
    ``extent_x_m`` by ``extent_y_m`` (module doc)."""
    return math.hypot(extent_x_m / theta_x_m, extent_y_m / theta_y_m) <= 1.0 / SINGLE_VARIABLE_MULTIPLE


class SingleValueField:
    """One standard normal value for every particle: the single-variable limit (module doc)."""

    method = "single"

    def __init__(self, n_particles: int):
        self.n_particles = n_particles

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Two independent fields, each one standard normal value at every particle."""
        a, b = rng.standard_normal(2)
        return np.full(self.n_particles, a), np.full(self.n_particles, b)

    def standard_normals(self, rng: np.random.Generator) -> np.ndarray:
        """The standard normal vector of one draw (as :meth:`draw` takes it from ``rng``)."""
        return rng.standard_normal(2)

    def field_of(self, xi: np.ndarray) -> np.ndarray:
        """The field of the standard normal vector ``xi``: its first value at every particle."""
        return np.full(self.n_particles, float(xi[0]))


class ExpandedField:
    """Standard Gaussian values at particles, each the average over its cell, from a Karhunen-Loeve
    expansion on a grid of nodes (module doc)."""

    method = "expansion"

    def __init__(self, model: CorrelationModel, theta_x_m: float, theta_y_m: float, x_m: np.ndarray, y_m: np.ndarray,
                 spacing_m: np.ndarray | float):
        x_m, y_m = np.asarray(x_m, float), np.asarray(y_m, float)
        spacing = np.broadcast_to(np.asarray(spacing_m, float), x_m.shape)
        half = 0.5 * float(spacing.max())
        low = (float(x_m.min()) - half, float(y_m.min()) - half)
        extent = (float(x_m.max()) + half - low[0], float(y_m.max()) + half - low[1])
        counts = _node_counts(extent, (theta_x_m, theta_y_m), float(spacing.min()))
        gx = low[0] + np.linspace(0.0, extent[0], counts[0])
        gy = low[1] + np.linspace(0.0, extent[1], counts[1])
        nodes_x, nodes_y = (a.ravel() for a in np.meshgrid(gx, gy, indexing="ij"))
        covariance = correlation(model, nodes_x[:, None] - nodes_x[None, :], nodes_y[:, None] - nodes_y[None, :],
                                 theta_x_m, theta_y_m)
        eigen, vectors = np.linalg.eigh(covariance)
        keep = eigen > EIGEN_FLOOR * eigen[-1]
        scaled = vectors[:, keep] / np.sqrt(eigen[keep])  # v_k / sqrt(lambda_k), (nodes, modes)
        cross = _cell_point_covariance(model, theta_x_m, theta_y_m, x_m, y_m, spacing, nodes_x, nodes_y)
        self.modes = cross @ scaled  # a_k(x) at each particle, (particles, modes)
        self.n_nodes, self.n_modes = nodes_x.size, int(keep.sum())
        gamma = {h: variance_function(model, h, h, theta_x_m, theta_y_m) for h in np.unique(spacing)}
        target = np.array([gamma[h] for h in spacing]) if len(gamma) > 1 else np.full(x_m.size, next(iter(gamma.values())))
        self.variance_kept = np.einsum("ij,ij->i", self.modes, self.modes) / target

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Two independent fields at the particles, cell-averaged (module doc)."""
        xi = rng.standard_normal((2, self.n_modes))
        return self.modes @ xi[0], self.modes @ xi[1]

    def standard_normals(self, rng: np.random.Generator) -> np.ndarray:
        """The standard normal vector of one draw (as :meth:`draw` takes it from ``rng``), raveled."""
        return rng.standard_normal((2, self.n_modes)).ravel()

    def field_of(self, xi: np.ndarray) -> np.ndarray:
        """The field at the particles of the standard normal vector ``xi``, linear in it: sum_k a_k(x) xi_k over
        the modes (the first field of :meth:`draw`)."""
        return self.modes @ xi[: self.n_modes]


def _node_counts(extent_m: tuple[float, float], theta_m: tuple[float, float], spacing_m: float) -> tuple[int, int]:
    """Nodes along x and y: a step of the particles' spacing, or coarser so that there are at most
    :data:`MAX_NODES`, and at least :data:`NODES_PER_THETA` per scale of fluctuation where that fits
    (both directions thinned alike when it does not); at least 2 per direction."""
    step = max(spacing_m, math.sqrt(extent_m[0] * extent_m[1] / MAX_NODES))
    counts = [int(math.ceil(length / min(step, theta / NODES_PER_THETA))) + 1
              for length, theta in zip(extent_m, theta_m)]
    if counts[0] * counts[1] > MAX_NODES:
        shrink = math.sqrt(MAX_NODES / (counts[0] * counts[1]))
        counts = [int(count * shrink) for count in counts]
    return max(2, counts[0]), max(2, counts[1])


CHUNK = 256
"""Particles per block of the cell-to-node covariance (a block is CHUNK x CELL_POINTS^2 x nodes values)."""


def _cell_point_covariance(model: CorrelationModel, theta_x_m: float, theta_y_m: float, x_m: np.ndarray, y_m: np.ndarray,
                           spacing_m: np.ndarray, nodes_x: np.ndarray, nodes_y: np.ndarray) -> np.ndarray:
    """c_j(x_i): the covariance of the average over particle i's cell (side its spacing, about it) with the
    point field at node j, by Gauss-Legendre quadrature (:data:`CELL_POINTS` per side); (particles, nodes)."""
    nodes, weights = np.polynomial.legendre.leggauss(CELL_POINTS)
    ox, oy = (a.ravel() for a in np.meshgrid(0.5 * nodes, 0.5 * nodes, indexing="ij"))  # in cells
    w = np.outer(weights, weights).ravel() / 4.0
    out = np.empty((x_m.size, nodes_x.size))
    for start in range(0, x_m.size, CHUNK):
        part = slice(start, start + CHUNK)
        px = x_m[part, None] + spacing_m[part, None] * ox[None, :]
        py = y_m[part, None] + spacing_m[part, None] * oy[None, :]
        rho = correlation(model, px[:, :, None] - nodes_x, py[:, :, None] - nodes_y, theta_x_m, theta_y_m)
        out[part] = np.einsum("q,pqj->pj", w, rho)
    return out
