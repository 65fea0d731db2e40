"""The static linear-elastic response of a cloud to its unbalanced force, by one sparse direct solve.

The smoothed strain of node k (``smoothing``) is linear in the nodal displacements u,

    eps_k = S_k u,   S_k = (1 / A_k) sum_{e ∋ k} (A_e / 3) B^e      (Voigt: xx, yy, gamma_xy),

and the internal force is its transpose (``nodal_force``), f_int = -sum_k A_k S_k^T sigma_k.  With
Hooke's law sigma_k = D_k eps_k (plane strain, the row's lambda and G) the stiffness of the nodally
integrated system is

    K = sum_k A_k S_k^T D_k S_k = S^T W S,     W = blockdiag(A_k D_k),

symmetric, and positive definite once the supports hold the rigid-body motions.  Given the unbalanced
force r (weight, water, surface loads and the current stress's internal force) on the free directions,

    K_ff du_f = r_f,   du = 0 where the velocity is prescribed (zero),

is the increment that brings an elastic body to small-strain equilibrium at once.  A relaxation of
elastic materials (a gravity stage) starts from it: its damped steps then only correct the
geometry of the large-deformation update, O(strain) of the load, instead of building the whole
stress wave by wave (``Simulation.relax``).  The bond stabilisation is a viscosity (it vanishes
at rest), so it does not enter K.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

VOIGT = 3  # eps_xx, eps_yy, gamma_xy


class NotSolvable(ValueError):
    """The direct solve does not apply (or failed); the relaxation steps from where it is."""


def strain_operator(node_xy: np.ndarray, elem_nodes: np.ndarray) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """(S, A): the smoothed strain operator (3 n x 2 n, rows 3k..3k+2 = eps_xx, eps_yy, gamma_xy of
    node k, columns 2I, 2I+1 = u_x, u_y of node I) and the cell areas A_k (module doc)."""
    n = node_xy.shape[0]
    xy = node_xy[elem_nodes]  # (n_elem, 3, 2)
    x, y = xy[..., 0], xy[..., 1]
    two_area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1) / two_area[:, None]
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1) / two_area[:, None]
    third_area = two_area / 6.0
    area = np.bincount(elem_nodes.ravel(), weights=np.repeat(third_area, 3), minlength=n)
    # every element adds (A_e / 3) B^e into each of its three nodes' rows: 3 nodes x 3 columns x 4 entries
    k = np.repeat(elem_nodes, 3, axis=1)  # (n_elem, 9): the row node, for each column node
    col = np.tile(elem_nodes, (1, 3))  # the column node
    w = np.repeat(third_area, 9).reshape(-1, 9)
    bb = np.tile(b, (1, 3)) * w
    cc = np.tile(c, (1, 3)) * w
    rows = np.concatenate([VOIGT * k, VOIGT * k + 1, VOIGT * k + 2, VOIGT * k + 2], axis=None)
    cols = np.concatenate([2 * col, 2 * col + 1, 2 * col, 2 * col + 1], axis=None)
    values = np.concatenate([bb, cc, cc, bb], axis=None)
    inv_area = np.divide(1.0, area, out=np.zeros(n), where=area > 0.0)
    values = values * np.repeat(inv_area, VOIGT)[rows]
    strain = scipy.sparse.csr_matrix((values, (rows, cols)), shape=(VOIGT * n, 2 * n))
    return strain, area


def elasticity_blocks(lame_lambda_pa: np.ndarray, shear_modulus_pa: np.ndarray) -> np.ndarray:
    """(n, 3, 3) plane-strain D of every node (Voigt with engineering shear)."""
    lam, g = lame_lambda_pa, shear_modulus_pa
    d = np.zeros((lam.size, 3, 3))
    d[:, 0, 0] = d[:, 1, 1] = lam + 2.0 * g
    d[:, 0, 1] = d[:, 1, 0] = lam
    d[:, 2, 2] = g
    return d


class ElasticSystem:
    """K_ff of a cloud on its mesh, factorised once (sparse LU); :meth:`increment` solves for a force.

    Built on the positions it is given.  Used again after the particles moved by an increment, it
    is a modified Newton iteration on the large-deformation equilibrium: the residual left by the
    geometry change is O(strain) of the load, and each further increment divides it by about as
    much again (``Simulation.solve_elastic``)."""

    def __init__(self, node_xy: np.ndarray, elem_nodes: np.ndarray, lame_lambda_pa: np.ndarray,
                 shear_modulus_pa: np.ndarray, free: np.ndarray):
        """Each node's ``lame_lambda_pa`` and ``shear_modulus_pa`` (n,); ``free`` (n, 2) the
        directions whose velocity is not prescribed.  NotSolvable when a node lies in no triangle or
        the supports leave a rigid-body motion free."""
        n = node_xy.shape[0]
        self.n_nodes = n
        self.strain, area = strain_operator(node_xy, elem_nodes)
        if np.any(area <= 0.0):
            raise NotSolvable(f"{int(np.sum(area <= 0.0))} particles lie in no triangle")
        self.lame_lambda_pa = np.asarray(lame_lambda_pa, dtype=np.float64)
        self.shear_modulus_pa = np.asarray(shear_modulus_pa, dtype=np.float64)
        weight = _block_diagonal(elasticity_blocks(self.lame_lambda_pa, self.shear_modulus_pa) * area[:, None, None])
        stiffness = (self.strain.T @ weight @ self.strain).tocsc()
        self.free_dofs = np.flatnonzero(np.asarray(free, dtype=bool).reshape(-1))
        if self.free_dofs.size == 0:
            raise NotSolvable("every direction is prescribed")
        try:
            self._lu = scipy.sparse.linalg.splu(stiffness[self.free_dofs][:, self.free_dofs].tocsc(), permc_spec="COLAMD")
        except RuntimeError as error:  # "Factor is exactly singular"
            raise NotSolvable(f"the stiffness is singular ({error}): the supports leave a rigid-body motion free") \
                from None

    def increment(self, unbalanced_force_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(du (n, 2) m, d_sigma (n, 4) Pa as xx, yy, zz, xy): the elastic increment that balances
        ``unbalanced_force_n`` (n, 2) on the free directions, du = 0 on the others (module doc)."""
        n = self.n_nodes
        du = np.zeros(2 * n)
        du[self.free_dofs] = self._lu.solve(np.asarray(unbalanced_force_n, dtype=np.float64).reshape(-1)[self.free_dofs])
        if not np.all(np.isfinite(du)):
            raise NotSolvable("the stiffness is singular: the supports leave a rigid-body motion free")
        eps = (self.strain @ du).reshape(n, VOIGT)
        lam, g = self.lame_lambda_pa, self.shear_modulus_pa
        volumetric = eps[:, 0] + eps[:, 1]
        d_sigma = np.empty((n, 4))
        d_sigma[:, 0] = lam * volumetric + 2.0 * g * eps[:, 0]
        d_sigma[:, 1] = lam * volumetric + 2.0 * g * eps[:, 1]
        d_sigma[:, 2] = lam * volumetric
        d_sigma[:, 3] = g * eps[:, 2]
        return du.reshape(n, 2), d_sigma


def _block_diagonal(blocks: np.ndarray) -> scipy.sparse.csr_matrix:
    """The block-diagonal sparse matrix of (n, 3, 3) ``blocks``."""
    n = blocks.shape[0]
    base = VOIGT * np.arange(n)[:, None, None]
    rows = np.broadcast_to(base + np.arange(VOIGT)[None, :, None], blocks.shape)
    cols = np.broadcast_to(base + np.arange(VOIGT)[None, None, :], blocks.shape)
    return scipy.sparse.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(VOIGT * n, VOIGT * n))
