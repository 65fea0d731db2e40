"""Steady groundwater flow on the particles' triangle mesh: the total head, the free surface and
the flow through the boundary.

The unknown is the total head h (m) at every particle (node) of the mesh (``spfem_core.mesh``:
linear triangles).  Darcy's law q = -k_r(psi) K grad h with the mass balance div q = 0 gives, on
each triangle of area A_e and constant shape-function gradients B_e (2 x 3),

    K_e = A_e B_e^T (k_r,e K_sat,e) B_e,      sum_e K_e h = Q,

Q the water a boundary puts in at each node (m2/s per metre of thickness; positive in).
K_sat = R(a) diag(k_1, k_2) R(a)^T is a material's saturated conductivity (m/s), k_1 along the
direction a from the horizontal.  A node's inflow Q_i = (K h)_i is what holds a fixed head there.

**Unconfined flow** (the free surface found on the fixed mesh).  Above the water table the soil
conducts only a residual fraction of its saturated conductivity: with the pressure head
psi = h - y at a triangle's centroid,

    k_r = 1                                          psi >= 0
    k_r = k_r0 + (1 - k_r0) (1 + psi / band)         -band < psi < 0      (a linear front)
    k_r = k_r0                                       psi <= -band

so that the phreatic surface (psi = 0) is where the flow leaves the saturated soil.  The heads
are found by Picard iteration: K is assembled with the k_r of the last heads and solved again,
a fraction of each update taken (halved whenever the full update grows, an oscillation of the
water table across the triangles; grown back towards 1 otherwise), until the change of h is below
``tolerance`` times the range of the fixed heads.

**Seepage face** (the "unknown: p = 0 or q = 0" condition).  A seepage-face node holds h = y
(atmospheric pressure) while water leaves through it (Q_i < 0), and is no-flow while its
pressure stays below atmospheric (h < y); a held node whose Q_i turns inflow is released, and a
released node whose head rises above its elevation is held again, each iteration, until no node
changes.  The exit point is the highest held node.

**Infiltration** (rain: the "unknown: p = 0 or q = q_rain" condition, SEEP/W's ponding review).
A rain node takes its given inflow q_i while its pressure stays at or below atmospheric; where the
ground cannot take the rain its head would rise above the surface (water standing on the ground
that nothing holds), so it holds h = y instead, taking in what the ground takes (Q_i <= q_i; the
rest runs off), and is released to its rain again once it would take in more than falls on it
(Q_i > q_i): the seepage face's rule with q_i in place of 0.  Where the water table reaches the
surface under the rain, the held node lets groundwater out (Q_i < 0), as a seepage face does.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse.linalg import spsolve

from spfem_core.flow_system import (  # noqa: F401  (shape_gradients, conductivity_tensor: also read from here)
    ElementConductivity,
    conductivity_tensor,
    darcy_velocity_m_s,
    shape_gradients,
    switch_atmospheric_nodes,
)


@dataclass(frozen=True)
class FlowProblem:
    """A steady flow problem on a triangle mesh (SI units; arrays per node or per element)."""

    node_xy_m: np.ndarray  # (n, 2)
    elem_nodes: np.ndarray  # (e, 3), counter-clockwise
    elem_conductivity_m_s: np.ndarray  # (e, 2, 2) saturated conductivity tensor K_sat
    node_fixed_head_m: np.ndarray  # (n,) the prescribed total head; NaN where none
    node_inflow_m2_s: np.ndarray  # (n,) given inflow (flux boundaries); 0 elsewhere
    node_seepage_face: np.ndarray  # (n,) bool: may hold h = y where water leaves
    residual_permeability: float = 1e-3  # k_r0
    unsaturated_band_m: float = 1.0  # band: the pressure head over which k_r falls to k_r0
    node_infiltration: np.ndarray | None = None  # (n,) bool: rain nodes, which hold h = y where the rain would
    # pond (module doc); None: none

    def infiltration(self) -> np.ndarray:
        """(n,) bool: the rain nodes (:attr:`node_infiltration`)."""
        if self.node_infiltration is None:
            return np.zeros(self.node_xy_m.shape[0], dtype=bool)
        return np.asarray(self.node_infiltration, dtype=bool)


@dataclass
class FlowSolution:
    """The heads of a steady flow problem and how they were found."""

    head_m: np.ndarray  # (n,) total head h
    node_inflow_m2_s: np.ndarray  # (n,) (K h)_i: the water each node takes in (out when negative)
    elem_relative_permeability: np.ndarray  # (e,) k_r of the last iteration
    elem_darcy_velocity_m_s: np.ndarray  # (e, 2) q = -k_r K_sat grad h
    node_held: np.ndarray  # (n,) bool: fixed head, or seepage-face or rain node held at h = y
    iterations: int
    converged: bool
    head_change_m: list[float] = field(default_factory=list)  # largest |delta h| of each iteration

    def pressure_head_m(self, node_xy_m: np.ndarray) -> np.ndarray:
        """psi = h - y at the nodes."""
        return self.head_m - node_xy_m[:, 1]


def relative_permeability(pressure_head_m: np.ndarray, residual: float, band_m: float) -> np.ndarray:
    """k_r(psi) at points (module doc; ``band_m`` 0: a step from ``residual`` to 1 at psi = 0)."""
    if band_m <= 0.0:
        return np.where(pressure_head_m >= 0.0, 1.0, residual)
    return np.clip(residual + (1.0 - residual) * (1.0 + pressure_head_m / band_m), residual, 1.0)


def _partial_expectation(low, mid, high, t):
    """E[(P - t)+] of P triangular on [low, high] with its mode at mid (arrays, low <= mid <= high): the
    distribution of a linear field's values over a triangle's area, its vertex values low, mid, high.
    Each piece is evaluated only where it applies (its denominators are positive there: no overflow
    from the pieces that do not, whatever t)."""
    low, mid, high = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (low, mid, high)))
    t = np.broadcast_to(np.asarray(t, dtype=float), low.shape)
    result = np.zeros(low.shape)  # t >= high
    below = t < low
    result[below] = (low[below] + mid[below] + high[below]) / 3.0 - t[below]
    upper = (t >= mid) & (t < high)  # so high > mid
    h, m, lo, tt = high[upper], mid[upper], low[upper], t[upper]
    result[upper] = (h - tt) ** 3 / (3.0 * (h - lo) * (h - m))
    within = (t >= low) & (t < mid)  # so mid > low
    h, m, lo, tt = high[within], mid[within], low[within], t[within]
    span = h - lo
    result[within] = (h - m) ** 2 / (3.0 * span) + (m - tt) - ((m - lo) ** 3 - (tt - lo) ** 3) / (3.0 * span * (m - lo))
    return result


def element_relative_permeability(node_pressure_head_m: np.ndarray, elem_nodes: np.ndarray, residual: float,
                                  band_m: float) -> np.ndarray:
    """k_r of each triangle: the mean of k_r(psi) over its area, psi linear between its nodes (exact: the
    values of a linear field over a triangle are distributed as the triangular distribution of its three
    vertex values).  With ``band_m`` 0 this is k_r0 + (1 - k_r0) times the saturated fraction of the area:
    the free surface crosses a triangle sharply, and k_r moves continuously with the heads."""
    psi = np.sort(node_pressure_head_m[elem_nodes], axis=1)
    low, mid, high = psi[:, 0], psi[:, 1], psi[:, 2]
    if band_m > 0.0:
        front = (_partial_expectation(low, mid, high, -band_m) - _partial_expectation(low, mid, high, 0.0)) / band_m
    else:  # P(psi >= 0) = 1 - F(0), each piece of F evaluated where it applies
        cdf = np.where((low < 0.0) & (0.0 >= high), 1.0, 0.0)  # 0 where 0 <= low
        rising = (low < 0.0) & (0.0 < high) & (0.0 <= mid)  # so mid > low
        cdf[rising] = low[rising] ** 2 / ((high[rising] - low[rising]) * (mid[rising] - low[rising]))
        falling = (mid < 0.0) & (0.0 < high)  # so high > mid
        cdf[falling] = 1.0 - high[falling] ** 2 / ((high[falling] - low[falling]) * (high[falling] - mid[falling]))
        front = 1.0 - cdf
    return residual + (1.0 - residual) * np.clip(front, 0.0, 1.0)


MIN_RELAXATION = 0.02
"""The smallest fraction of a Picard update taken (module doc): 0.05 left the perched-water study
(studies/seepage_perched.toml) oscillating for ever, 0.02 settles it in about 560 iterations."""
RELAXATION_GROWTH = 1.05
"""After an update that did not grow, the fraction taken grows by this factor, back towards 1."""


def head_scale_m(problem: FlowProblem) -> float:
    """The length the iteration's tolerance is relative to: the larger of the range of the fixed heads
    (and of the seepage faces' elevations) and the mesh's height."""
    y = problem.node_xy_m[:, 1]
    fixed = np.isfinite(problem.node_fixed_head_m)
    face = problem.node_seepage_face & ~fixed
    heads = np.concatenate([problem.node_fixed_head_m[fixed], y[face]])
    return float(max(np.ptp(heads) if heads.size else 0.0, np.ptp(y), 1e-12))


def solve_steady_flow(problem: FlowProblem, tolerance: float = 1e-6, max_iterations: int = 2000) -> FlowSolution:
    """The steady heads of ``problem`` (module doc): Picard iteration on k_r, the seepage face and the rain
    nodes until the largest head change is below ``tolerance`` times the range of the fixed heads and
    no seepage-face or rain node changes; ValueError when no node has a fixed head or a seepage face
    (the heads would be undetermined)."""
    xy = problem.node_xy_m
    y = xy[:, 1]
    fixed = np.isfinite(problem.node_fixed_head_m)
    face = problem.node_seepage_face & ~fixed
    may_hold = face | (problem.infiltration() & ~fixed)  # may hold h = y: seepage faces, rain nodes
    if not fixed.any() and not face.any():
        raise ValueError("seepage: no boundary fixes a head (total head, pressure head, seepage face or ponded "
                         "water): the heads are undetermined")
    system = ElementConductivity(problem.node_xy_m, problem.elem_nodes, problem.elem_conductivity_m_s)
    scale = head_scale_m(problem)
    held_face = face.copy()  # start with every face node at atmospheric pressure, every rain node on its rain
    head = np.where(fixed, problem.node_fixed_head_m, np.max(np.concatenate(
        [problem.node_fixed_head_m[fixed], y[face]])))
    kr = np.ones(problem.elem_nodes.shape[0])
    changes: list[float] = []
    relaxation, last_update = 1.0, None
    converged = False
    for _ in range(max_iterations):
        held = fixed | held_face
        target = np.where(fixed, problem.node_fixed_head_m, y)
        matrix = system.matrix(kr)
        free = ~held
        new = target.copy()
        if free.any():
            rhs = problem.node_inflow_m2_s[free] - matrix[free][:, held] @ target[held]
            new[free] = spsolve(matrix[free][:, free].tocsc(), rhs)
        update = float(np.max(np.abs(new - head)))
        if last_update is not None and update > last_update:
            relaxation = max(MIN_RELAXATION, 0.5 * relaxation)  # the update grew: a Picard oscillation, damp it
        elif relaxation < 1.0:
            relaxation = min(1.0, RELAXATION_GROWTH * relaxation)
        last_update = update
        change = relaxation * update
        changes.append(change)
        head = head + relaxation * (new - head)
        inflow = matrix @ head
        # seepage faces and rain: release held nodes that take in more than their flux (0 on a face), hold
        # released ones above atmospheric
        held_face, switched = switch_atmospheric_nodes(held_face, may_hold, inflow, problem.node_inflow_m2_s, head - y)
        kr = element_relative_permeability(head - y, problem.elem_nodes, problem.residual_permeability,
                                           problem.unsaturated_band_m)
        if change <= tolerance * scale and not switched:
            converged = True
            break
    matrix = system.matrix(kr)
    velocity = darcy_velocity_m_s(kr, problem.elem_conductivity_m_s, system.b, head[problem.elem_nodes])
    return FlowSolution(head, matrix @ head, kr, velocity, fixed | held_face, len(changes), converged, changes)


def phreatic_segments(node_xy_m: np.ndarray, elem_nodes: np.ndarray, pressure_head_m: np.ndarray) -> np.ndarray:
    """(s, 2, 2) the segments of the phreatic surface psi = 0 across the triangles where psi changes
    sign (linear within each triangle)."""
    psi = pressure_head_m[elem_nodes]  # (e, 3)
    segments = []
    for e in np.flatnonzero((psi.min(axis=1) < 0.0) & (psi.max(axis=1) >= 0.0)):
        points = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            pa, pb = psi[e, a], psi[e, b]
            if (pa < 0.0) != (pb < 0.0):
                t = pa / (pa - pb)
                xa, xb = node_xy_m[elem_nodes[e, a]], node_xy_m[elem_nodes[e, b]]
                points.append(xa + t * (xb - xa))
        if len(points) == 2:
            segments.append(points)
    return np.array(segments, dtype=float).reshape(-1, 2, 2)
