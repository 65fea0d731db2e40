"""Critical time step of the explicit scheme: a bound on the highest frequency of the
nodally integrated (node-based smoothed) elastic system.

Leapfrog is stable for dt <= 2 / omega_max, omega_max^2 the largest eigenvalue of M^-1 K.
The stiffness is a sum over smoothing cells, K = sum_k K_k with K_k = A_k B_k^T D_k B_k
(rank 3), and the lumped mass can be split over the cells too: node j gives the share
m_j / (n_j + 1) to its own cell and to each of its n_j mesh neighbours' cells (the cells
whose strain it enters).  The cell-by-cell bound (Fried's element-by-element bound applied
to cells) then gives

    omega_max^2 <= max_k lambda_max(D_k^1/2 G_k D_k^1/2),
    G_k = (1 / A_k) sum_j g_kj g_kj^T / (m_j / (n_j + 1)),

with g_kj = A_k B_kj = sum_{e ∋ k, j} (A_e / 3) B_j^e: each term is an edge vector of e over
six, so no element area divides anything.  The run uses dt = cfl * dt_crit with

    dt_crit = 2 / sqrt(max_k lambda_max(...))   (a 3x3 eigenvalue per cell).

Why not the element rule sqrt(A_e) / c_p: particle masses are fixed, and in 2D an element's
stiffness does not change when it shrinks (B ~ 1/l, A ~ l^2), so a tight pair or triple of
particles (a tiny element) barely moves the true stable step, while sqrt(A_e) went to zero:
on a 12 x 12 lattice the element rule was 7x too pessimistic with a pair at 0.05 h and 1500x
with a triple at 0.001 h, and granular flows raised "the mesh degenerated" on such pairs.
Dense eigenvalues of the same clouds (``tests/test_timestep.py``) give true step / this
bound = 1.47 on the lattice (the element rule: 1.48, so runs on lattices keep their step)
and 1.47-1.67 on jittered, sheared, compressed and crowded clouds (the element rule: 1.34-1500).

Which step a stage takes (:class:`TimeStepPolicy`): ``dt_s`` when the settings give one,
else cfl * dt_crit; anything above max_stable_cfl(beta) * dt_crit is refused.  A relaxation
steps at that largest accepted step whatever the settings (only its end state counts).
After a mesh rebuild the step follows the new dt_crit.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.jit import inner_kernel, kernel

DT_COLLAPSE_FACTOR = 1e-3
"""Divergence when a rebuilt mesh would cut the time step below this fraction of the stage's
first time step: the mesh has degenerated (particles piling onto each other)."""


class UnstableTimeStepError(ValueError):
    """A requested time step above the critical step of the explicit scheme."""


def max_stable_cfl(beta: float) -> float:
    """Largest accepted cfl for stabilisation ``beta``: 1 / (1 + beta).

    The stabilisation is a bond viscosity proportional to beta dt, so it lowers the stable
    step.  Measured by ``python -m benchmarks.stability_limit`` on the beam lattice: limits
    1.51, 1.46, 1.32, 0.94 for beta = 0, 0.1, 0.3, 1 (jittered cloud: 1.68, 1.57, 1.38, 0.80);
    the rule keeps a margin of at least 1.5 on all of them.
    """
    return 1.0 / (1.0 + max(beta, 0.0))


class TimeStepPolicy:
    """The time step of a run from its ``scene.SolverSettings`` and the mesh's dt_crit (module doc)."""

    def __init__(self, settings):
        self.settings = settings
        self.max_cfl = max_stable_cfl(settings.stabilisation_beta)

    def dynamic(self, critical_dt_s: float) -> float:
        """The step of a dynamic stage on a mesh with ``critical_dt_s``; UnstableTimeStepError if
        the settings ask for more than the stable limit."""
        settings = self.settings
        beta = settings.stabilisation_beta
        if settings.dt_s is not None:
            limit = self.max_cfl * critical_dt_s
            if not 0.0 < settings.dt_s <= limit:
                raise UnstableTimeStepError(
                    f"dt_s = {settings.dt_s:.4g} s is above the stable time step {limit:.4g} s "
                    f"(2 / the bound on the highest frequency of the mesh, spfem_core.timestep, "
                    f"times {self.max_cfl:.3g} for beta = {beta:g}); use dt_s <= {limit:.4g} or set cfl instead"
                )
            return float(settings.dt_s)
        if not 0.0 < settings.cfl <= self.max_cfl:
            raise UnstableTimeStepError(
                f"cfl = {settings.cfl:g} is outside (0, {self.max_cfl:.3g}], the stable range for "
                f"beta = {beta:g} (limit 1 / (1 + beta))"
            )
        return settings.cfl * critical_dt_s

    def relaxation(self, critical_dt_s: float, beta: float) -> float:
        """The step of a relaxation with stabilisation ``beta``: the largest accepted one,
        max_stable_cfl(beta) dt_crit."""
        return max_stable_cfl(beta) * critical_dt_s

    def after_rebuild(self, critical_dt_s: float, relaxation_beta: float | None) -> float:
        """The step on a rebuilt mesh: a fixed ``dt_s`` is kept while it is stable, a cfl is
        applied to the new dt_crit (a relaxation, with its ``relaxation_beta``, keeps its largest
        accepted cfl; None: not a relaxation)."""
        if relaxation_beta is not None:
            return self.relaxation(critical_dt_s, relaxation_beta)
        dt_s = self.settings.dt_s
        if dt_s is not None and dt_s <= self.max_cfl * critical_dt_s:
            return float(dt_s)
        return min(self.settings.cfl, self.max_cfl) * critical_dt_s


@inner_kernel
def _largest_eigenvalue_sym3(s00, s01, s02, s11, s12, s22):
    """Largest eigenvalue of a symmetric 3x3 matrix (trigonometric closed form)."""
    off = s01 * s01 + s02 * s02 + s12 * s12
    q = (s00 + s11 + s22) / 3.0
    p2 = (s00 - q) * (s00 - q) + (s11 - q) * (s11 - q) + (s22 - q) * (s22 - q) + 2.0 * off
    if p2 <= 1e-30 * (q * q + 1e-300):
        return q
    p = math.sqrt(p2 / 6.0)
    b00, b11, b22 = (s00 - q) / p, (s11 - q) / p, (s22 - q) / p
    b01, b02, b12 = s01 / p, s02 / p, s12 / p
    r = 0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02))
    r = min(max(r, -1.0), 1.0)
    return q + 2.0 * p * math.cos(math.acos(r) / 3.0)


@kernel
def critical_time_step(node_xy, elem_nodes, node_node_ptr, node_node_idx, node_mass, node_material_row, mat_lambda,
                       mat_shear):
    """2 / sqrt(cell-by-cell bound of omega_max^2) in s (module doc); inf for an empty mesh."""
    omega_sq = _cell_omega_sq(node_xy, elem_nodes, node_node_ptr, node_node_idx, node_mass, node_material_row,
                              mat_lambda, mat_shear)
    omega_sq_max = 0.0
    for p in range(omega_sq.shape[0]):
        if not omega_sq[p] <= omega_sq_max:  # NaN (positions not finite) gives dt = 0
            omega_sq_max = omega_sq[p] if omega_sq[p] == omega_sq[p] else math.inf
    if omega_sq_max <= 0.0:
        return math.inf
    return 2.0 / math.sqrt(omega_sq_max)


@kernel
def cell_frequency_bounds(node_xy, elem_nodes, node_node_ptr, node_node_idx, node_mass, node_material_row,
                          mat_lambda, mat_shear):
    """Per smoothing cell k, lambda_max(D_k^1/2 G_k D_k^1/2) in 1/s^2 (module doc): the bound on
    omega^2 that cell k sets; 0 for a particle outside the mesh."""
    return _cell_omega_sq(node_xy, elem_nodes, node_node_ptr, node_node_idx, node_mass, node_material_row,
                          mat_lambda, mat_shear)


@inner_kernel
def _cell_omega_sq(node_xy, elem_nodes, node_node_ptr, node_node_idx, node_mass, node_material_row, mat_lambda,
                   mat_shear):
    n = node_xy.shape[0]
    g_self = np.zeros((n, 2))  # g_kk per node
    g_pair = np.zeros((node_node_idx.shape[0], 2))  # g_kj per CSR slot of j in k's neighbours
    cell_area = np.zeros(n)
    sixth = 1.0 / 6.0
    for e in range(elem_nodes.shape[0]):
        v0, v1, v2 = elem_nodes[e, 0], elem_nodes[e, 1], elem_nodes[e, 2]
        third_area = ((node_xy[v1, 0] - node_xy[v0, 0]) * (node_xy[v2, 1] - node_xy[v0, 1])
                      - (node_xy[v2, 0] - node_xy[v0, 0]) * (node_xy[v1, 1] - node_xy[v0, 1])) * sixth
        for a in range(3):
            p = elem_nodes[e, a]
            cell_area[p] += third_area
            for b in range(3):
                # (A_e / 3) grad N_q^e: the edge opposite vertex b, rotated, over 6
                q = elem_nodes[e, b]
                n1 = elem_nodes[e, (b + 1) % 3]
                n2 = elem_nodes[e, (b + 2) % 3]
                gx = (node_xy[n1, 1] - node_xy[n2, 1]) * sixth
                gy = (node_xy[n2, 0] - node_xy[n1, 0]) * sixth
                if q == p:
                    g_self[p, 0] += gx
                    g_self[p, 1] += gy
                    continue
                for slot in range(node_node_ptr[p], node_node_ptr[p + 1]):
                    if node_node_idx[slot] == q:
                        g_pair[slot, 0] += gx
                        g_pair[slot, 1] += gy
                        break
    omega_sq = np.zeros(n)
    for p in range(n):
        area = cell_area[p]
        if not area > 0.0:
            continue
        # G_p = sum_q g g^T / m_share, in Voigt form (xx, yy, engineering xy)
        g00 = 0.0
        g11 = 0.0
        g01 = 0.0  # B_q B_q^T has no (xx, yy) term
        g02 = 0.0
        g12 = 0.0
        g22 = 0.0
        for slot in range(node_node_ptr[p] - 1, node_node_ptr[p + 1]):
            if slot < node_node_ptr[p]:
                q = p
                bx, by = g_self[p, 0], g_self[p, 1]
            else:
                q = node_node_idx[slot]
                bx, by = g_pair[slot, 0], g_pair[slot, 1]
            w = (node_node_ptr[q + 1] - node_node_ptr[q] + 1.0) / node_mass[q]
            # B_q = [[bx, 0], [0, by], [by, bx]]  ->  B_q B_q^T
            g00 += w * bx * bx
            g11 += w * by * by
            g22 += w * (bx * bx + by * by)
            g02 += w * bx * by
            g12 += w * bx * by
        inv_area = 1.0 / area
        g00 *= inv_area
        g11 *= inv_area
        g22 *= inv_area
        g02 *= inv_area
        g12 *= inv_area
        # D^1/2 for plane strain: eigenvalues 2 (lambda + G) on (1, 1, 0), 2 G on (1, -1, 0), G on (0, 0, 1)
        m = node_material_row[p]
        lam = mat_lambda[m]
        shear = mat_shear[m]
        ra = math.sqrt(2.0 * (lam + shear))
        rb = math.sqrt(2.0 * shear)
        d0 = 0.5 * (ra + rb)  # diagonal of the 2x2 block
        d1 = 0.5 * (ra - rb)  # off-diagonal of the 2x2 block
        d2 = math.sqrt(shear)
        # S = Dh G Dh, Dh = [[d0, d1, 0], [d1, d0, 0], [0, 0, d2]]
        t00 = d0 * g00 + d1 * g01
        t01 = d0 * g01 + d1 * g11
        t02 = d0 * g02 + d1 * g12
        t10 = d1 * g00 + d0 * g01
        t11 = d1 * g01 + d0 * g11
        t12 = d1 * g02 + d0 * g12
        t22 = d2 * g22
        s00 = t00 * d0 + t01 * d1
        s01 = t00 * d1 + t01 * d0
        s02 = t02 * d2
        s11 = t10 * d1 + t11 * d0
        s12 = t12 * d2
        s22 = t22 * d2
        omega_sq[p] = _largest_eigenvalue_sym3(s00, s01, s02, s11, s12, s22)
    return omega_sq


def equalised_inertia(inertia_kg: np.ndarray, omega_sq: np.ndarray, node_node_ptr: np.ndarray,
                      node_node_idx: np.ndarray) -> np.ndarray:
    """Inertia under which no cell bounds omega^2 above the median cell's bound: density scaling to
    a uniform critical step, as explicit static solvers (FLAC) do it for a relaxation.

    Cell k's bound ``omega_sq[k]`` (:func:`cell_frequency_bounds`) is linear in the inverse inertias
    of its stencil (k and its mesh neighbours), so multiplying each of them by
    r_k = omega_k^2 / omega_median^2 divides it by at least r_k.  Each particle takes the largest
    factor of the cells it enters:

        m_i,j = m_j max(1, max_{k : j in stencil(k)} omega_k^2 / omega_median^2).

    On a uniform cloud the cells that hold the step down are the free surface's (fewer
    neighbours): on the reference slope at h = 0.3 m the median cell's step is 2.0 times the
    smallest, and 2.5% of the particles take more inertia.  A target below the median (more
    particles scaled) measured no fewer steps (docs/method.md, section 5).
    """
    positive = omega_sq[omega_sq > 0.0]
    if not positive.size:
        return inertia_kg.copy()
    ratio = np.maximum(omega_sq / float(np.median(positive)), 1.0)
    factor = ratio.copy()
    np.maximum.at(factor, node_node_idx, np.repeat(ratio, np.diff(node_node_ptr)))
    return inertia_kg * factor
