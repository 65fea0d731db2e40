"""Groundwater flow on linear triangles: what the steady and the transient solvers share
(``spfem_core.seepage``, ``spfem_core.transient_seepage``).

- **Shape gradients**: on a triangle of area A with counter-clockwise vertices, the constant
  gradients of its shape functions, grad N_a = (y_b - y_c, x_c - x_b) / (2 A) (a, b, c cyclic): B (2 x 3).
- **Conductivity tensor**: K_sat = R(a) diag(k_1, k_2) R(a)^T, k_1 along the direction a from the
  horizontal (m/s).
- **Element conductivity matrices**: K_e = A_e B_e^T K_sat,e B_e (3 x 3), computed once; a solver
  scales each by the triangle's relative conductivity k_r,e and sums them into the global matrix
  sum_e k_r,e K_e.  The steady solver sums the triplets as scipy's COO conversion does (its results
  are pinned to the bit); the transient solver, which assembles several times per time step, adds
  them into a CSC pattern computed once (``np.bincount`` on a precomputed position of each
  triplet, about six times faster; the two sums differ by round-off).  The pattern is symmetric,
  so the same arrays are the matrix's CSR and CSC forms.
- **Lumped areas**: a node's share of the area, sum over its triangles of A_e / 3 (the row sums of
  the consistent mass matrix of linear triangles).
- **Darcy velocity** of a triangle: q_e = -k_r,e K_sat,e B_e h_e (m/s).
- **The seepage-face rule** (the "unknown: p = 0 or q = 0" condition, and a surface that ponds):
  a node that may be held at atmospheric pressure is held while the water the hold needs does not
  exceed what the boundary supplies there (none on a seepage face, the rain on a rained-on
  surface: beyond it the water would have to be sucked in), and a released node whose pressure
  head rises above 0 is held again.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse


def shape_gradients(node_xy_m: np.ndarray, elem_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(B (e, 2, 3), area A (e,)) of linear triangles: grad N_a = (y_b - y_c, x_c - x_b) / (2 A)."""
    xy = node_xy_m[elem_nodes]  # (e, 3, 2)
    x, y = xy[..., 0], xy[..., 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    area = 0.5 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    return np.stack([b, c], axis=1) / (2.0 * area)[:, None, None], area


def conductivity_tensor(k1_m_s, k2_m_s, angle_deg) -> np.ndarray:
    """K = R diag(k1, k2) R^T, k1 along ``angle_deg`` from the horizontal (arrays broadcast; (..., 2, 2))."""
    a = np.radians(np.asarray(angle_deg, dtype=float))
    c, s = np.cos(a), np.sin(a)
    k1, k2 = np.asarray(k1_m_s, dtype=float), np.asarray(k2_m_s, dtype=float)
    return np.stack([np.stack([k1 * c * c + k2 * s * s, (k1 - k2) * c * s], axis=-1),
                     np.stack([(k1 - k2) * c * s, k1 * s * s + k2 * c * c], axis=-1)], axis=-2)


def darcy_velocity_m_s(elem_relative_conductivity: np.ndarray, elem_conductivity_m_s: np.ndarray,
                       shape_gradient: np.ndarray, elem_head_m: np.ndarray) -> np.ndarray:
    """(e, 2) q = -k_r K_sat B h of each triangle (``elem_head_m`` (e, 3): its nodes' total heads)."""
    return -np.einsum("eij,ejb,eb->ei", elem_relative_conductivity[:, None, None] * elem_conductivity_m_s,
                      shape_gradient, elem_head_m)


def switch_atmospheric_nodes(held: np.ndarray, may_hold: np.ndarray, needed_inflow: np.ndarray,
                             supplied_inflow: np.ndarray, pressure_head_m: np.ndarray,
                             hold_above_m: float = 0.0) -> tuple[np.ndarray, bool]:
    """(the nodes held at psi = 0 after the seepage-face rule (module doc), whether any changed).

    ``needed_inflow``: the water each node takes in at the present heads (what a held node's hold
    supplies); ``supplied_inflow``: what the boundary gives it when released (0 on a seepage face);
    a released node is held when its pressure head exceeds ``hold_above_m`` (the transient solver's
    head tolerance: at the instant a surface starts to pond, held it needs a little more than the
    rain and released it rises a little above 0, and a threshold of 0 would switch it for ever)."""
    release = held & (needed_inflow - supplied_inflow > 0.0)
    hold = may_hold & ~held & (pressure_head_m > hold_above_m)
    return (held & ~release) | hold, bool(release.any() or hold.any())


class ElementConductivity:
    """The element conductivity matrices of a mesh (module doc) and their assembly."""

    def __init__(self, node_xy_m: np.ndarray, elem_nodes: np.ndarray, elem_conductivity_m_s: np.ndarray,
                 who: str = "seepage"):
        self.b, self.area = shape_gradients(node_xy_m, elem_nodes)
        if np.any(self.area <= 0.0):
            raise ValueError(f"{who}: every triangle must be counter-clockwise with a positive area")
        # K_e (sat) = A B^T K B
        self.k_sat_elem = self.area[:, None, None] * np.einsum("eia,eij,ejb->eab", self.b, elem_conductivity_m_s,
                                                              self.b)
        self.elem_nodes = elem_nodes
        self.rows = np.repeat(elem_nodes, 3, axis=1).ravel()
        self.cols = np.tile(elem_nodes, (1, 3)).ravel()
        self.n = node_xy_m.shape[0]
        self._pattern = None

    def matrix(self, kr: np.ndarray) -> sparse.csr_matrix:
        """sum_e k_r,e K_e, the triplets summed by scipy's COO conversion (the steady solver's)."""
        data = (kr[:, None, None] * self.k_sat_elem).ravel()
        return sparse.csr_matrix((data, (self.rows, self.cols)), shape=(self.n, self.n))

    def lumped_area_m2(self) -> np.ndarray:
        """(n,) each node's share of the area: sum of A_e / 3 over its triangles."""
        return np.bincount(self.elem_nodes.ravel(), weights=np.repeat(self.area / 3.0, 3), minlength=self.n)

    @property
    def pattern(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(indptr, indices, position of each triplet in the data, position of each node's diagonal):
        the symmetric sparsity pattern of the global matrix (module doc), computed on first use."""
        if self._pattern is None:
            n = self.n
            keys = self.rows * n + self.cols
            unique, position = np.unique(keys, return_inverse=True)
            indptr = np.searchsorted(unique // n, np.arange(n + 1))
            indices = unique % n
            diagonal = np.searchsorted(unique, np.arange(n) * (n + 1))
            if not np.array_equal(unique[np.minimum(diagonal, unique.size - 1)], np.arange(n) * (n + 1)):
                raise ValueError("transient seepage: a node belongs to no triangle (its head is undetermined)")
            self._pattern = (indptr, indices, position.ravel(), diagonal)
        return self._pattern

    def assembled_data(self, kr: np.ndarray) -> np.ndarray:
        """The data array of sum_e k_r,e K_e on :attr:`pattern` (module doc)."""
        _, indices, position, _ = self.pattern
        return np.bincount(position, weights=(kr[:, None, None] * self.k_sat_elem).ravel(), minlength=indices.size)
