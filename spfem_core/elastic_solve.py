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

:func:`solve_elastic` is that start (``Simulation.solve_elastic``): where the direct solve applies,
the solves and the re-solves of the residual the moved geometry leaves, with the same factorisation
(:class:`ElasticSystem`), until the relaxation has nothing left to do.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from spfem_core.state import SLIP_SIDE, STRESS_WIDTH, XX, XY, YY, ZZ
from spfem_core.stepper import unbalanced_force_at_rest

VOIGT_STRAIN = ("xx", "yy", "gamma_xy")
"""Components of a strain in Voigt form (engineering shear gamma_xy = 2 eps_xy): the rows of the
strain operator of a node, and of its D."""
EPS_XX, EPS_YY, GAMMA_XY = range(len(VOIGT_STRAIN))
VOIGT = len(VOIGT_STRAIN)

SOLVE_MARGIN = 0.1
""":func:`solve_elastic` solves until the unbalanced-force ratio is below this times the
relaxation's tolerance, so that the damped steps after it have nothing left to do."""
MAX_SOLVES = 4
"""At most this many direct solves per relaxation (two reach 3.1e-7 on the reference slope)."""
SOLVE_GAIN = 0.1
"""Each solve must divide the unbalanced-force ratio by at least 1 / this, or the state goes back to
how it was and the damped steps relax it (a stiffness the supports leave near singular, whose LU
does not fail outright, would otherwise move the particles by its round-off)."""
DIRECT_SOLVE_MAX_DOFS = 120_000
"""Larger clouds relax without the direct solve: the sparse LU's fill grows faster than the
relaxation's steps (the reference slope's gravity stage on one thread, solves against damped
steps: 6,927 particles 0.45 s against 0.80 s, 27,120 particles 3.6 s against 7.5 s;
``python -m benchmarks.relaxation_steps --spacing 0.3 0.15``)."""


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
    rows = np.concatenate([VOIGT * k + EPS_XX, VOIGT * k + EPS_YY, VOIGT * k + GAMMA_XY, VOIGT * k + GAMMA_XY],
                          axis=None)
    cols = np.concatenate([2 * col, 2 * col + 1, 2 * col, 2 * col + 1], axis=None)
    values = np.concatenate([bb, cc, cc, bb], axis=None)
    inv_area = np.divide(1.0, area, out=np.zeros(n), where=area > 0.0)
    values = values * np.repeat(inv_area, VOIGT)[rows]
    strain = scipy.sparse.csr_matrix((values, (rows, cols)), shape=(VOIGT * n, 2 * n))
    return strain, area


def elasticity_blocks(lame_lambda_pa: np.ndarray, shear_modulus_pa: np.ndarray) -> np.ndarray:
    """(n, 3, 3) plane-strain D of every node (Voigt with engineering shear)."""
    lam, g = lame_lambda_pa, shear_modulus_pa
    d = np.zeros((lam.size, VOIGT, VOIGT))
    d[:, EPS_XX, EPS_XX] = d[:, EPS_YY, EPS_YY] = lam + 2.0 * g
    d[:, EPS_XX, EPS_YY] = d[:, EPS_YY, EPS_XX] = lam
    d[:, GAMMA_XY, GAMMA_XY] = g
    return d


class ElasticSystem:
    """K_ff of a cloud on its mesh, factorised once (sparse LU); :meth:`increment` solves for a force.

    Built on the positions it is given.  Used again after the particles moved by an increment, it
    is a modified Newton iteration on the large-deformation equilibrium: the residual left by the
    geometry change is O(strain) of the load, and each further increment divides it by about as
    much again (:func:`solve_elastic`)."""

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
        """(du (n, 2) m, d_sigma (n, 4) Pa, columns ``state.STRESS``): the elastic increment that balances
        ``unbalanced_force_n`` (n, 2) on the free directions, du = 0 on the others (module doc)."""
        n = self.n_nodes
        du = np.zeros(2 * n)
        du[self.free_dofs] = self._lu.solve(np.asarray(unbalanced_force_n, dtype=np.float64).reshape(-1)[self.free_dofs])
        if not np.all(np.isfinite(du)):
            raise NotSolvable("the stiffness is singular: the supports leave a rigid-body motion free")
        eps = (self.strain @ du).reshape(n, VOIGT)
        lam, g = self.lame_lambda_pa, self.shear_modulus_pa
        volumetric = eps[:, EPS_XX] + eps[:, EPS_YY]
        d_sigma = np.empty((n, STRESS_WIDTH))
        d_sigma[:, XX] = lam * volumetric + 2.0 * g * eps[:, EPS_XX]
        d_sigma[:, YY] = lam * volumetric + 2.0 * g * eps[:, EPS_YY]
        d_sigma[:, ZZ] = lam * volumetric
        d_sigma[:, XY] = g * eps[:, GAMMA_XY]
        return du.reshape(n, 2), d_sigma


def _block_diagonal(blocks: np.ndarray) -> scipy.sparse.csr_matrix:
    """The block-diagonal sparse matrix of (n, 3, 3) ``blocks``."""
    n = blocks.shape[0]
    base = VOIGT * np.arange(n)[:, None, None]
    rows = np.broadcast_to(base + np.arange(VOIGT)[None, :, None], blocks.shape)
    cols = np.broadcast_to(base + np.arange(VOIGT)[None, None, :], blocks.shape)
    return scipy.sparse.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(VOIGT * n, VOIGT * n))


def why_not_direct(sim) -> str | None:
    """Why the direct solve does not give the state a relaxation of ``sim`` (a
    ``simulation.Simulation``) approaches, or None: it does where every material is elastic, the
    supports hold still, there are no walls, no particle slides along a slip support (an elastic
    row holds them fixed), no load ramp, every particle lies in a triangle, and the LU stays small
    (:data:`DIRECT_SOLVE_MAX_DOFS`)."""
    nodes = sim.nodes
    if sim.materials.plastic:
        return "a material is not elastic"
    if sim.walls.xy_m.shape[0]:
        return "walls"
    if np.any(nodes.slip[:, SLIP_SIDE] != 0.0):  # (an elastic row on a slip support is held fixed)
        return "slip supports"
    if sim.prescribes_motion:
        return "prescribed motion"
    if sim.loads.ramp_time_s > 0.0:
        return "a load ramp"
    if sim.n_orphans:
        return "particles outside the mesh"
    if np.count_nonzero(~nodes.fixed) > DIRECT_SOLVE_MAX_DOFS:
        return f"more than {DIRECT_SOLVE_MAX_DOFS} free directions"
    return None


def solve_elastic(sim, tolerance: float) -> str:
    """Bring the particles of ``sim`` to static equilibrium by direct solves where that applies
    (:func:`why_not_direct`).  The unbalanced force at rest (weight, water and loads at the
    current stage time, the current stress) is balanced by the small-strain increment, the
    particles move by it and take its stress; the residual the moved geometry leaves is solved
    again with the same factorisation, until the unbalanced-force ratio is below
    :data:`SOLVE_MARGIN` x ``tolerance`` (at most :data:`MAX_SOLVES` times; each must divide it by
    1 / :data:`SOLVE_GAIN`, else the state is put back).  At rest afterwards.  Returns one line:
    what was done, or why not.  On the reference slope at h = 0.3 m the ratio fell
    1 -> 2.9e-4 -> 3.1e-7."""
    reason = why_not_direct(sim)
    if reason is not None:
        return f"not applicable ({reason})"
    nodes = sim.nodes
    start = time.perf_counter()
    row = nodes.material_row
    free = ~nodes.fixed
    weight_sq = float(np.sum((nodes.mass_kg[:, None] * sim.gravity_m_s2[None, :])[free] ** 2))
    unbalanced = np.zeros((sim.n_particles, 2))
    before = (nodes.xy_m.copy(), nodes.displacement_m.copy(), nodes.stress_pa.copy())
    try:
        system = ElasticSystem(nodes.xy_m, sim.mesh.elem_nodes, sim.material_arrays.lame_lambda_pa[row],
                               sim.material_arrays.shear_modulus_pa[row], free)
        ratios = []
        for _ in range(MAX_SOLVES + 1):
            unbalanced_force_at_rest(nodes, sim.scratch, sim.mesh_arrays, sim.material_arrays, sim.loads,
                                     sim.gravity_m_s2, 0.0, unbalanced)
            ratios.append(math.sqrt(float(np.sum(unbalanced[free] ** 2)) / weight_sq) if weight_sq > 0 else 0.0)
            if len(ratios) > 1 and not ratios[-1] < SOLVE_GAIN * ratios[-2]:
                raise NotSolvable(f"a solve left the unbalanced-force ratio at {ratios[-1]:.3g} from "
                                  f"{ratios[-2]:.3g}: the stiffness is near singular or the geometry moved too far")
            if ratios[-1] < SOLVE_MARGIN * tolerance or len(ratios) > MAX_SOLVES:
                break
            du, d_stress = system.increment(unbalanced)
            nodes.xy_m[:] += du
            nodes.displacement_m[:] += du
            nodes.stress_pa[:] += d_stress
    except NotSolvable as error:
        nodes.xy_m[:], nodes.displacement_m[:], nodes.stress_pa[:] = before  # as it was: the steps relax it
        return f"not applicable ({error})"
    nodes.velocity_m_s[:] = 0.0
    sim.update_critical_dt()
    trail = " -> ".join(f"{r:.2g}" for r in ratios)
    return (f"{len(ratios) - 1} direct solves in {time.perf_counter() - start:.2f} s, unbalanced-force ratio "
            f"{trail}")
