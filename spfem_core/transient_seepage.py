"""Transient unsaturated groundwater flow on the particles' triangle mesh: Richards' equation in
mixed form, with time-dependent boundary conditions (rain, reservoir levels, seepage faces).

**Equation.** With the pressure head psi (m), the total head h = psi + y (y up), a material's
water content theta(psi), effective saturation S_e(psi), relative conductivity k_r(psi) and
specific storage S_s (``spfem_core.soil_water``) and its saturated conductivity tensor K_sat
(anisotropic, as the steady solver's: ``spfem_core.flow_system``),

    d theta / dt + S_s S_e dpsi / dt = div(k_r(psi) K_sat grad h).

**Discretisation.** Linear triangles (the mesh and element matrices of the steady solver) with
lumped storage: node i holds the water W_i = sum_m M_i^m theta_m(psi_i), M_i^m its share of the area
of the triangles of material m (A_e / 3 from each), so that a node on a material interface stores
each material's water in its part.  The conductivity of a triangle is k_r,e K_sat,e with
k_r,e = (k_r(psi_a) + k_r(psi_b) + k_r(psi_c)) / 3, the arithmetic mean of its nodes' values in its
material: the integral over the triangle of k_r interpolated linearly between its nodes, the
consistent choice of linear elements (HYDRUS's).  A geometric or harmonic mean lets a dry node choke
the flow into its triangles; on Srivastava & Yeh's columns the arithmetic mean is the more accurate
of the three at every spacing tried (docs/method.md).  Backward Euler in time from t_n to
t_n+1 = t_n + dt: the residual of node i, its water balance (m2/s per metre),

    F_i = (W_i(psi) - W_i^n) / dt + S_i(psi) (psi_i - psi_i^n) / dt + (A(psi) h)_i - Q_i,

with S_i = sum_m M_i^m S_s,m S_e,m(psi_i), A(psi) = sum_e k_r,e A_e B_e^T K_sat,e B_e and Q_i the water
a flux boundary supplies (its mean over the step: a rainfall history's volume is applied exactly
whatever the step).

**Modified Picard iteration** (Celia, Bouloutas & Zarba 1990): W(psi^(m+1)) ~ W(psi^m) + Cap^m
(psi^(m+1) - psi^m), Cap_i = sum_m M_i^m C_m(psi_i) the lumped moisture capacity, gives

    J delta = [diag(Cap^m + S^m) / dt + A(psi^m)] delta = -F(psi^m),      psi^(m+1) = psi^m + w delta,

the nodes whose head a condition holds eliminated (J stays symmetric positive definite).  The
iteration stops when the largest |delta| is below ``head_tolerance_m`` and the residual's magnitude
dt sum_free |F_i| is below ``balance_tolerance`` times the magnitude of the step's water balance
(sum |storage change| + dt sum |boundary flows|).  Because the residual is the mass balance itself
(the mixed form: theta, not C dpsi/dt, is differenced in time), the water that enters less the
water stored is -dt sum_free F_i: each step's balance closes to the tolerance, whatever Cap (Celia
et al.'s point against the head form, whose error does not vanish with the iteration).
- w is Irons & Tuck's (1969) dynamic relaxation (within [``min_relaxation``, ``max_relaxation``]):
  near saturation van Genuchten's k_r rises with an infinite slope for n < 2, the Picard update
  overshoots and would oscillate for ever.  Even so a node that hovers at psi = 0 while its
  surface starts to pond has no Picard fixed point closer than about 1e-7 of its flux (k_r jumps by
  that much within 1e-11 m of saturation at n = 1.6): hence the default ``balance_tolerance``.
- Each step starts from the last step's trend continued, psi^n + dt (psi^n - psi^n-1) / dt_n-1:
  fewer iterations a step, hence longer steps (docs/method.md, section 17).
- **Linear solves**: J is factorized by scipy's SuperLU (minimum-degree ordering of J + J^T,
  diagonal pivots); later iterations and steps solve by conjugate gradients preconditioned with the
  last factors, to a relative residual of ``LINEAR_TOLERANCE``, and factorize again only when that
  takes more than ``REFACTOR_AFTER`` iterations (a factorization costs 20-30 solves with the factors
  at 7,000 nodes).

**Time step.** After a converged step the step grows by ``growth`` when the iteration took at most
``easy_iterations``, shrinks by ``shrink`` when it took more than ``hard_iterations``; a step that
does not converge in ``max_iterations`` (or whose seepage faces keep switching) is cut by ``cut``
and done again from t_n.  Steps end on every saved time and every point of the conditions'
histories (a drawdown's or a rainfall's change of rate is not smeared), and a step shortened to
such a point does not count for growth.  A step cut below ``min_step_s`` stops the solve with a
ValueError saying when.

**Boundary conditions** (:class:`HeadBoundary`, :class:`ReservoirBoundary`, :class:`FluxBoundary`,
:class:`SeepageFace`; a node belongs to the last one that names it; other boundary nodes are
no-flow): a total head or pressure head given as a history (:class:`History`: points (t, value),
linear between, constant beyond); a reservoir level h(t), which holds h = h(t) on its nodes at or
below the level and makes those above a seepage face; a flux q(t) (m/s, positive in) whose nodal
weights come from the boundary edges it covers (:func:`boundary_flux_weights_m`: each edge's length,
or its horizontal length for rain per horizontal area) and which ponds: a node whose pressure
head would rise above 0 (above ``head_tolerance_m``: the ponding instant has no consistent state
closer than that) is held at psi = 0, and released when the water the hold draws in exceeds the flux
(``spfem_core.flow_system.switch_atmospheric_nodes``, the steady solver's seepage-face rule, checked
every iteration); a seepage face: the same rule with no flux.  A negative flux is evaporation, the
atmosphere's demand: where the soil cannot supply it the surface dries to the limit the air sets, and
with ``FluxBoundary.dry_limit_m`` psi_d a node whose pressure head would fall below psi_d (by more than
``head_tolerance_m``) while the flux is upward is held at psi = psi_d, and released when the water the
hold draws out exceeds the demand (:func:`switch_dry_nodes`; the "atmospheric" condition of HYDRUS and
of Lu & Griffiths 2004: |q| at most the demand, psi_d <= psi <= 0).  A head may vary along its boundary
(``HeadBoundary.offset_m``).

**Unloading**: the water a reservoir leaves on the ground is a vertical load; where it changes by a depth
dD of water, the total stress below changes by gamma_w dD and, for saturated soil that cannot drain at once,
so does its pore pressure (Skempton's B-bar; the one-dimensional loading of consolidation theory).  The
storage term becomes S_i (psi_i - psi_i^n - zeta dD_i) (``ReservoirBoundary.loading_efficiency`` zeta,
dD_i the change over the step of the water standing above node i): at zero permeability a drawdown lowers
the pressure head under the face by the water removed (the rapid-drawdown limit, B-bar = 1), at high
permeability the flow relaxes it, and between them the two compete.  The stored water counts the same
term (the water the unloaded skeleton draws in).

**Initial state**: given heads (the steady solution), or hydrostatic from a water table,
psi = y_wt - y, optionally not below -suction_limit (:func:`hydrostatic_head_m`).

**Mass balance** (per metre of thickness, m2): the stored water V(t) = sum_i W_i + the storage term
summed over the steps (sum_i S_i (psi_i^n+1 - psi_i^n - zeta dD_i)); each condition's inflow summed over the
steps (at a held node the water the hold supplies, F_i + Q_i at the converged heads; at a released
flux node Q_i).  The error of a step is its inflow less its storage change, computed from these
sums independently of the residual.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import SuperLU, splu

from spfem_core.flow_system import ElementConductivity, darcy_velocity_m_s, switch_atmospheric_nodes
from spfem_core.soil_water import SoilWaterCurve

WHO = "transient seepage"


class FlowNotConverged(ValueError):
    """The Picard iteration does not converge even at ``min_step_s``: the problem is too hard for the
    mesh or the step (an input error of the caller's contract raises a plain ValueError)."""


@dataclass(frozen=True)
class History:
    """A quantity against time: points (t_k, v_k) with t_k non-decreasing, linear between them and
    constant beyond them (a repeated time makes a step)."""

    times_s: np.ndarray
    values: np.ndarray

    def __post_init__(self):
        times = np.asarray(self.times_s, dtype=float).ravel()
        values = np.asarray(self.values, dtype=float).ravel()
        if times.size == 0 or times.size != values.size:
            raise ValueError(f"history: need as many times as values (at least one), got {times.size} and {values.size}")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise ValueError("history: times and values must be finite")
        if np.any(np.diff(times) < 0.0):
            raise ValueError("history: times must not decrease")
        object.__setattr__(self, "times_s", times)
        object.__setattr__(self, "values", values)

    @classmethod
    def constant(cls, value: float) -> History:
        """The same value at every time."""
        return cls(np.array([0.0]), np.array([float(value)]))

    def at(self, time_s: float) -> float:
        """v(t), linear between the points (at a repeated time: the later value)."""
        t, v = self.times_s, self.values
        k = int(np.searchsorted(t, time_s, side="right")) - 1
        if k < 0:
            return float(v[0])
        if k >= t.size - 1:
            return float(v[-1])
        return float(v[k] + (v[k + 1] - v[k]) * (time_s - t[k]) / (t[k + 1] - t[k]))

    def _integral_s(self, time_s: float) -> float:
        """int_t0^t v (negative before t0)."""
        t, v = self.times_s, self.values
        if time_s <= t[0]:
            return (time_s - t[0]) * v[0]
        cumulative = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (v[1:] + v[:-1]))])
        k = min(int(np.searchsorted(t, time_s, side="right")) - 1, t.size - 1)
        return float(cumulative[k] + 0.5 * (time_s - t[k]) * (v[k] + self.at(time_s))) if k < t.size - 1 else float(
            cumulative[-1] + (time_s - t[-1]) * v[-1])

    def mean(self, start_s: float, end_s: float) -> float:
        """(1 / (t1 - t0)) int_t0^t1 v dt, exact for the piecewise-linear history."""
        return (self._integral_s(end_s) - self._integral_s(start_s)) / (end_s - start_s)


@dataclass(frozen=True)
class HeadBoundary:
    """A prescribed total head h(t) on ``nodes`` (bool (n,)), or with ``pressure`` the pressure head
    psi(t) (h = y + psi); plus ``offset_m[i]`` at node i if given (a head that varies along the boundary,
    the steady solution's on a far side)."""

    name: str
    nodes: np.ndarray
    head_m: History
    pressure: bool = False
    offset_m: np.ndarray | None = None


@dataclass(frozen=True)
class ReservoirBoundary:
    """A reservoir whose level is h(t): h = h(t) on its nodes at or below the level, a seepage face above.
    With ``ground_above_m`` (n,), the height of the ground surface its water stands on vertically above each
    node (+inf where none of its water stands), a change of the water's load on that ground changes the pore
    pressure below by ``loading_efficiency`` times its depth of water (module doc, "Unloading")."""

    name: str
    nodes: np.ndarray
    level_m: History
    ground_above_m: np.ndarray | None = None
    loading_efficiency: float = 0.0

    def load_head_m(self, time_s: float) -> np.ndarray | float:
        """The loading efficiency times the depth of the reservoir's water standing above each node (m)."""
        if self.ground_above_m is None or self.loading_efficiency == 0.0:
            return 0.0
        return self.loading_efficiency * np.maximum(self.level_m.at(time_s) - self.ground_above_m, 0.0)


@dataclass(frozen=True)
class FluxBoundary:
    """A flux q(t) (m/s, positive in): node i takes node_weight_m[i] q(t) (m2/s per metre), and is held at
    psi = 0 where the surface ponds (unless ``ponds`` is False); while q < 0 (evaporation), held at
    psi = ``dry_limit_m`` where the soil cannot supply the demand (None: no limit; module doc)."""

    name: str
    node_weight_m: np.ndarray
    flux_m_s: History
    ponds: bool = True
    dry_limit_m: float | None = None

    @property
    def nodes(self) -> np.ndarray:
        return self.node_weight_m > 0.0


@dataclass(frozen=True)
class SeepageFace:
    """Nodes held at psi = 0 while water leaves through them, no-flow otherwise."""

    name: str
    nodes: np.ndarray


Boundary = HeadBoundary | ReservoirBoundary | FluxBoundary | SeepageFace


def boundary_flux_weights_m(node_xy_m: np.ndarray, edges: np.ndarray, per_horizontal_length: bool) -> np.ndarray:
    """(n,) the water each node takes per unit flux: half of each boundary edge (a, b) it ends, times the
    edge's length, or its horizontal length |x_b - x_a| for a flux per horizontal area (rain)."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    d = node_xy_m[edges[:, 1]] - node_xy_m[edges[:, 0]]
    length = np.abs(d[:, 0]) if per_horizontal_length else np.hypot(d[:, 0], d[:, 1])
    return np.bincount(edges.ravel(), weights=np.repeat(0.5 * length, 2), minlength=node_xy_m.shape[0])


def hydrostatic_head_m(node_xy_m: np.ndarray, water_table_y_m, suction_limit_m: float | None = None) -> np.ndarray:
    """The total head of hydrostatic water below a water table y_wt (a height, or one per node):
    psi = y_wt - y, not below -``suction_limit_m`` if given; h = y + psi."""
    y = node_xy_m[:, 1]
    psi = np.asarray(water_table_y_m, dtype=float) - y
    if suction_limit_m is not None:
        psi = np.maximum(psi, -float(suction_limit_m))
    return y + psi


@dataclass(frozen=True)
class TransientProblem:
    """A transient flow problem on a triangle mesh (SI units; per node or per element)."""

    node_xy_m: np.ndarray  # (n, 2)
    elem_nodes: np.ndarray  # (e, 3), counter-clockwise
    elem_conductivity_m_s: np.ndarray  # (e, 2, 2) K_sat
    elem_material: np.ndarray  # (e,) index into curves
    curves: tuple[SoilWaterCurve, ...]  # one per material
    boundaries: tuple[Boundary, ...]  # a node belongs to the last that names it
    initial_head_m: np.ndarray  # (n,)


@dataclass(frozen=True)
class TransientSettings:
    """The iteration and the time step (module doc)."""

    initial_step_s: float = 60.0
    min_step_s: float = 1e-3
    max_step_s: float = 86400.0
    head_tolerance_m: float = 1e-4
    balance_tolerance: float = 1e-7
    max_iterations: int = 30
    easy_iterations: int = 5
    hard_iterations: int = 10
    growth: float = 1.5
    shrink: float = 0.7
    cut: float = 0.3
    min_relaxation: float = 0.05
    max_relaxation: float = 1.0

    def __post_init__(self):
        if not (0.0 < self.min_step_s <= self.max_step_s and math.isfinite(self.max_step_s)
                and 0.0 < self.initial_step_s and math.isfinite(self.initial_step_s)):
            raise ValueError(f"{WHO}: need 0 < min_step_s <= max_step_s (finite) and a finite initial_step_s > 0, got "
                             f"{self.min_step_s}, {self.max_step_s}, {self.initial_step_s}")
        if not (self.head_tolerance_m > 0.0 and self.balance_tolerance > 0.0 and self.max_iterations >= 2):
            raise ValueError(f"{WHO}: the tolerances must be > 0 and max_iterations >= 2")
        if not (self.growth >= 1.0 and 0.0 < self.shrink <= 1.0 and 0.0 < self.cut < 1.0):
            raise ValueError(f"{WHO}: need growth >= 1, 0 < shrink <= 1, 0 < cut < 1")
        if not (0 <= self.easy_iterations <= self.hard_iterations <= self.max_iterations):
            raise ValueError(f"{WHO}: need easy_iterations <= hard_iterations <= max_iterations")
        if not (0.0 < self.min_relaxation <= self.max_relaxation):
            raise ValueError(f"{WHO}: need 0 < min_relaxation <= max_relaxation")


@dataclass
class TransientSolution:
    """The state at each saved time (the first is the initial state) and the water balance."""

    times_s: np.ndarray  # (k,)
    head_m: np.ndarray  # (k, n) total head h
    water_content: np.ndarray  # (k, n) theta: W_i / M_i (the lumped mean where materials meet)
    effective_saturation: np.ndarray  # (k, n) the lumped mean of S_e
    elem_darcy_velocity_m_s: np.ndarray  # (k, e, 2) q = -k_r K_sat grad h
    node_held: np.ndarray  # (k, n) nodes held at psi = 0 by a ponding surface, a seepage face or a reservoir's
    #                          face, or at its dry limit by an evaporating surface
    boundary_names: tuple[str, ...]
    boundary_inflow_m2_s: np.ndarray  # (k, b) the water each condition let in over the step before each time
    boundary_cumulative_inflow_m2: np.ndarray  # (k, b) since t = 0 (negative: out)
    water_in_m2: np.ndarray  # (k,) all the water that entered since t = 0 (at the nodes that took it in)
    water_out_m2: np.ndarray  # (k,) all the water that left
    stored_water_m2: np.ndarray  # (k,) V: the lumped water plus the storage term since t = 0
    balance_error_m2: np.ndarray  # (k,) cumulative inflow less (V - V_0)
    step_end_s: np.ndarray  # (s,) every accepted step
    step_s: np.ndarray
    step_iterations: np.ndarray
    step_balance_error_m2: np.ndarray  # inflow less storage change of each step
    step_balance_scale_m2: np.ndarray  # sum |storage change| + dt sum |boundary flows| of each step
    rejected_steps: int = 0
    solves: int = 0  # linear solves (Picard iterations)
    factorizations: int = 0  # of which by a new LU factorization (the others: conjugate gradients)

    def pressure_head_m(self, node_xy_m: np.ndarray) -> np.ndarray:
        """(k, n) psi = h - y."""
        return self.head_m - node_xy_m[None, :, 1]

    def balance_fraction(self) -> np.ndarray:
        """(k,) |cumulative error| over the largest of |V - V_0|, the water in and the water out, at each time;
        in a closed domain (no water in or out at all) over the water its steps moved between nodes (the sum of
        their sum |storage change|), as its V - V_0 is rounding alone."""
        change = np.abs(self.stored_water_m2 - self.stored_water_m2[0])
        scale = np.maximum(np.maximum(change, self.water_in_m2), self.water_out_m2)
        if not (np.any(self.water_in_m2) or np.any(self.water_out_m2)):
            moved = np.concatenate([[0.0], np.cumsum(self.step_balance_scale_m2)])
            scale = moved[np.searchsorted(self.step_end_s, self.times_s, side="right")]
        return np.abs(self.balance_error_m2) / np.maximum(scale, 1e-300)

    def step_balance_fractions(self) -> np.ndarray:
        """Each step's |error| over its balance's magnitude (module doc)."""
        return np.abs(self.step_balance_error_m2) / np.maximum(self.step_balance_scale_m2, 1e-300)


class _Materials:
    """The lumped water of the nodes, per material (module doc)."""

    def __init__(self, problem: TransientProblem, area_m2: np.ndarray):
        elem = problem.elem_nodes
        n = problem.node_xy_m.shape[0]
        material = np.asarray(problem.elem_material, dtype=np.int64)
        if material.shape != (elem.shape[0],) or material.min(initial=0) < 0 or material.max(
                initial=0) >= len(problem.curves):
            raise ValueError(f"{WHO}: elem_material must give each triangle the index of one of the "
                             f"{len(problem.curves)} curves")
        self.groups = []  # (curve, element indices, its nodes, (e_m, 3) positions in them, M^m at them)
        for m, curve in enumerate(problem.curves):
            elems = np.flatnonzero(material == m)
            if elems.size == 0:
                continue
            nodes, local = np.unique(elem[elems], return_inverse=True)
            local = local.reshape(-1, 3)
            lumped = np.bincount(local.ravel(), weights=np.repeat(area_m2[elems] / 3.0, 3), minlength=nodes.size)
            self.groups.append((curve, elems, nodes, local, lumped))
        self.n, self.n_elem = n, elem.shape[0]

    def state(self, psi: np.ndarray):
        """(W, Cap, S, sum_m M^m S_e,m, k_r,e): the lumped water, capacity, storage coefficient and saturation of
        each node, and each triangle's relative conductivity, at the pressure heads ``psi``."""
        water, capacity, storage, saturation = (np.zeros(self.n) for _ in range(4))
        kr = np.empty(self.n_elem)
        for curve, elems, nodes, local, lumped in self.groups:
            values = curve.values(psi[nodes])
            water[nodes] += lumped * values.water_content
            capacity[nodes] += lumped * values.moisture_capacity_1_m
            storage[nodes] += lumped * curve.specific_storage_1_m * values.effective_saturation
            saturation[nodes] += lumped * values.effective_saturation
            node_kr = values.relative_conductivity[local]
            kr[elems] = (node_kr[:, 0] + node_kr[:, 1] + node_kr[:, 2]) / 3.0
        return water, capacity, storage, saturation, kr


class _Conditions:
    """The boundaries' nodes (a node to the last boundary that names it) and their values at a time."""

    def __init__(self, problem: TransientProblem):
        n = problem.node_xy_m.shape[0]
        self.y = problem.node_xy_m[:, 1]
        self.owner = np.full(n, -1, dtype=np.int64)
        for index, boundary in enumerate(problem.boundaries):
            nodes = np.asarray(boundary.nodes, dtype=bool)
            if nodes.shape != (n,):
                raise ValueError(f"{WHO}: boundary {boundary.name!r}: its nodes must be a bool array of {n}")
            self.owner[nodes] = index
            offset = getattr(boundary, "offset_m", None)
            if offset is not None and np.shape(offset) != (n,):
                raise ValueError(f"{WHO}: boundary {boundary.name!r}: offset_m must hold one head per node ({n})")
            if isinstance(boundary, FluxBoundary) and boundary.dry_limit_m is not None and not (
                    math.isfinite(boundary.dry_limit_m) and boundary.dry_limit_m < 0.0):
                raise ValueError(f"{WHO}: boundary {boundary.name!r}: dry_limit_m must be a finite pressure head below "
                                 f"0, got {boundary.dry_limit_m}")
            if isinstance(boundary, ReservoirBoundary):
                if boundary.ground_above_m is not None and np.shape(boundary.ground_above_m) != (n,):
                    raise ValueError(f"{WHO}: boundary {boundary.name!r}: ground_above_m must hold one height per "
                                     f"node ({n})")
                if not 0.0 <= boundary.loading_efficiency <= 1.0:
                    raise ValueError(f"{WHO}: boundary {boundary.name!r}: loading_efficiency must lie in [0, 1], "
                                     f"got {boundary.loading_efficiency}")
        self.boundaries = problem.boundaries
        self.mine = [self.owner == i for i in range(len(problem.boundaries))]

    def breakpoints_s(self) -> np.ndarray:
        """Every time at which a condition's history has a point."""
        times = [b.head_m.times_s if isinstance(b, HeadBoundary) else b.level_m.times_s if isinstance(
            b, ReservoirBoundary) else b.flux_m_s.times_s for b in self.boundaries if not isinstance(b, SeepageFace)]
        return np.unique(np.concatenate(times)) if times else np.zeros(0)

    def load_change_m(self, start_s: float, end_s: float) -> np.ndarray:
        """(n,) the change of zeta times the reservoirs' water standing above each node over the step (module
        doc, "Unloading")."""
        change = np.zeros(self.y.size)
        for boundary in self.boundaries:
            if isinstance(boundary, ReservoirBoundary):
                change += boundary.load_head_m(end_s) - boundary.load_head_m(start_s)
        return change

    def at(self, start_s: float, end_s: float):
        """(target total head, NaN where free; may hold psi = 0; the dry limit psi_d of each node that may be
        held there, NaN elsewhere; supplied inflow Q (mean over the step))."""
        n = self.y.size
        target = np.full(n, np.nan)
        may_hold = np.zeros(n, dtype=bool)
        dry_limit = np.full(n, np.nan)
        supplied = np.zeros(n)
        for boundary, mine in zip(self.boundaries, self.mine):
            if isinstance(boundary, HeadBoundary):
                value = boundary.head_m.at(end_s) + (0.0 if boundary.offset_m is None else boundary.offset_m[mine])
                target[mine] = self.y[mine] + value if boundary.pressure else value
            elif isinstance(boundary, ReservoirBoundary):
                level = boundary.level_m.at(end_s)
                under = mine & (self.y <= level)
                target[under] = level
                may_hold |= mine & ~under
            elif isinstance(boundary, FluxBoundary):
                flux = boundary.flux_m_s.mean(start_s, end_s)
                supplied[mine] = boundary.node_weight_m[mine] * flux
                if boundary.ponds:
                    may_hold |= mine
                if boundary.dry_limit_m is not None and flux < 0.0:
                    dry_limit[mine] = boundary.dry_limit_m
            else:
                may_hold |= mine
        return target, may_hold, dry_limit, supplied


@dataclass
class _Step:
    """A converged step: the new pressure heads and held nodes, the lumped state, the water each node took in."""

    psi: np.ndarray
    held: np.ndarray  # at psi = 0
    dry: np.ndarray  # at the dry limit
    water: np.ndarray
    storage: np.ndarray
    saturation: np.ndarray
    kr: np.ndarray
    node_inflow: np.ndarray  # m2/s: F_i + Q_i at held nodes, Q_i at released ones
    load_change_m: np.ndarray  # zeta dD_i: the unloading's share of the step's change of pressure head
    scale_m2: float  # sum |storage change| + dt sum |boundary flows|
    iterations: int


class _Solver:
    def __init__(self, problem: TransientProblem, settings: TransientSettings):
        self.problem, self.settings = problem, settings
        xy = problem.node_xy_m
        self.y = xy[:, 1]
        self.system = ElementConductivity(xy, problem.elem_nodes, problem.elem_conductivity_m_s, who=WHO)
        self.indptr, self.indices, _, self.diagonal = self.system.pattern
        self.column_of_entry = np.repeat(np.arange(self.y.size), np.diff(self.indptr))
        self.materials = _Materials(problem, self.system.area)
        self.lumped = self.system.lumped_area_m2()
        self.conditions = _Conditions(problem)
        self.solves = self.factorizations = 0
        self._factors: SuperLU | None = None
        n = self.y.size
        self._stiffness, self._jacobian = (sparse.csc_matrix((np.zeros(self.indices.size), self.indices, self.indptr),
                                                             shape=(n, n)) for _ in range(2))

    def _roundoff_m2(self, stiffness: np.ndarray, psi: np.ndarray, dt: float) -> float:
        """The residual's rounding, dt ROUNDOFF sum_i sum_j |A_ij| |psi_j + y_j|: water at rest moves no water, so
        the balance's own scale is 0 and only this bounds a residual that is rounding alone."""
        return dt * ROUNDOFF * float(np.sum(self._on(self._stiffness, np.abs(stiffness)) @ np.abs(psi + self.y)))

    @staticmethod
    def _on(matrix: sparse.csc_matrix, data: np.ndarray) -> sparse.csc_matrix:
        """``matrix`` (the pattern) holding ``data`` (not copied)."""
        matrix.data = data
        return matrix

    def linear_solve(self, matrix: sparse.csc_matrix, rhs: np.ndarray) -> np.ndarray | None:
        """J delta = rhs (module doc, "Linear solves"); None when J is singular."""
        self.solves += 1
        if self._factors is not None:
            delta = _preconditioned_cg(matrix, rhs, self._factors.solve, LINEAR_TOLERANCE, REFACTOR_AFTER)
            if delta is not None:
                return delta
        try:
            self._factors = splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                 options={"SymmetricMode": True})
        except RuntimeError:  # singular: a part of the mesh with neither storage nor a held head
            self._factors = None
            return None
        self.factorizations += 1
        delta = self._factors.solve(rhs)
        return delta if np.all(np.isfinite(delta)) else None

    def step(self, psi_old: np.ndarray, water_old: np.ndarray, held_old: np.ndarray, dry_old: np.ndarray,
             start_s: float, dt: float, guess: np.ndarray) -> _Step | None:
        """The modified Picard iteration of one step (module doc); None when it does not converge."""
        s = self.settings
        target, may_hold, dry_limit, supplied = self.conditions.at(start_s, start_s + dt)
        load_change = self.conditions.load_change_m(start_s, start_s + dt)
        fixed = np.isfinite(target)
        may_hold &= ~fixed
        may_dry = np.isfinite(dry_limit) & ~fixed
        held = held_old & may_hold
        dry = dry_old & may_dry
        psi = guess.copy()
        psi[fixed] = target[fixed] - self.y[fixed]
        change = math.inf
        relaxation, last_update, last_held = 1.0, None, None
        for iteration in range(s.max_iterations + 1):
            water, capacity, storage, saturation, kr = self.materials.state(psi)
            stiffness = self.system.assembled_data(kr)
            stored = (water - water_old) + storage * (psi - psi_old - load_change)
            residual = stored / dt + self._on(self._stiffness, stiffness) @ (psi + self.y) - supplied
            held, switched = switch_atmospheric_nodes(held, may_hold, residual + supplied, supplied, psi,
                                                      s.head_tolerance_m)
            dry, dried = switch_dry_nodes(dry, may_dry & ~held, residual + supplied, supplied, psi, dry_limit,
                                          s.head_tolerance_m)
            switched |= dried
            every_held = fixed | held | dry
            scale = np.sum(np.abs(stored)) + dt * (np.sum(np.abs(supplied)) + np.sum(np.abs(residual[every_held])))
            unbalanced = dt * np.sum(np.abs(residual[~every_held]))
            if iteration > 0 and change <= s.head_tolerance_m and not switched and (
                    unbalanced <= s.balance_tolerance * scale or unbalanced <= self._roundoff_m2(stiffness, psi, dt)):
                inflow = np.where(every_held, residual + supplied, supplied)
                return _Step(psi, held, dry, water, storage, saturation, kr, inflow, load_change, float(scale),
                             iteration)
            if iteration == s.max_iterations:
                return None
            data = stiffness.copy()
            data[self.diagonal] += (capacity + storage) / dt
            held_psi = np.where(fixed, target - self.y, np.where(dry, dry_limit, 0.0))
            delta_held = np.where(every_held, held_psi - psi, 0.0)
            jacobian = self._on(self._jacobian, data)
            rhs = -residual - jacobian @ delta_held
            rhs[every_held] = delta_held[every_held]
            data[every_held[self.indices] | every_held[self.column_of_entry]] = 0.0  # the held rows and columns
            data[self.diagonal[every_held]] = 1.0
            delta = self.linear_solve(jacobian, rhs)
            if delta is None:
                return None
            free = ~every_held
            if last_update is not None and np.array_equal(every_held, last_held):
                relaxation = _aitken(relaxation, last_update[free], delta[free], s.min_relaxation, s.max_relaxation)
            else:
                relaxation = 1.0
            last_update, last_held = delta, every_held
            psi = psi + np.where(free, relaxation * delta, delta)
            change = float(np.max(np.abs(delta)))
        return None


def switch_dry_nodes(dry: np.ndarray, may_dry: np.ndarray, needed_inflow: np.ndarray, supplied_inflow: np.ndarray,
                     pressure_head_m: np.ndarray, dry_limit_m: np.ndarray, hold_below_m: float = 0.0
                     ) -> tuple[np.ndarray, bool]:
    """(the nodes held at their dry limit after the rule of the module doc, whether any changed).

    ``needed_inflow``: the water each node takes in at the present heads (what a held node's hold supplies:
    negative, drawn out); ``supplied_inflow``: what the boundary gives it when released (the demand, negative);
    a held node is released when its hold draws out more than the demand, a released node that may dry is held
    when its pressure head is below its limit ``dry_limit_m`` by more than ``hold_below_m``."""
    release = dry & (needed_inflow - supplied_inflow < 0.0)
    hold = may_dry & ~dry & (pressure_head_m < dry_limit_m - hold_below_m)
    return (dry & ~release) | hold, bool(release.any() or hold.any())


ROUNDOFF = 1e-12
"""The relative rounding of a flux sum A (psi + y) that counts as no imbalance: far above the double
precision of its terms (2.2e-16 each), far below ``balance_tolerance``."""
LINEAR_TOLERANCE = 1e-6
"""A conjugate-gradient solve stops when |rhs - J delta| <= this times |rhs|."""
REFACTOR_AFTER = 12
"""Conjugate-gradient iterations after which the old factors are dropped and J factorized again."""


def _preconditioned_cg(matrix: sparse.csc_matrix, rhs: np.ndarray, precondition, tolerance: float,
                       max_iterations: int) -> np.ndarray | None:
    """The conjugate-gradient solution of matrix x = rhs preconditioned by ``precondition`` (an SPD
    approximation of its inverse), from x = 0; None when it has not converged in ``max_iterations``.
    Factors made for a matrix far from this one can make the iterates overflow: that is
    a solve that failed (None, and the caller factorizes again), not a warning."""
    with np.errstate(over="ignore", invalid="ignore"):
        return _cg_iterations(matrix, rhs, precondition, tolerance, max_iterations)


def _cg_iterations(matrix: sparse.csc_matrix, rhs: np.ndarray, precondition, tolerance: float,
                   max_iterations: int) -> np.ndarray | None:
    """:func:`_preconditioned_cg`'s iterations."""
    x = np.zeros_like(rhs)
    r = rhs.copy()
    bound = tolerance * float(np.linalg.norm(rhs))
    if bound == 0.0:
        return x
    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    for _ in range(max_iterations):
        q = matrix @ p
        curvature = float(p @ q)
        if not curvature > 0.0:
            return None
        step = rz / curvature
        x += step * p
        r -= step * q
        if float(np.linalg.norm(r)) <= bound:
            return x if np.all(np.isfinite(x)) else None
        z = precondition(r)
        rz, last = float(r @ z), rz
        p = z + (rz / last) * p
    return None


def _aitken(relaxation: float, last: np.ndarray, update: np.ndarray, low: float, high: float) -> float:
    """Irons & Tuck's (1969) dynamic relaxation of a fixed-point iteration: with the raw updates r_m-1, r_m,
    w_m = -w_m-1 r_m-1 . (r_m - r_m-1) / |r_m - r_m-1|^2, kept within [low, high]."""
    difference = update - last
    squared = float(difference @ difference)
    if squared == 0.0:
        return relaxation
    return float(np.clip(-relaxation * float(last @ difference) / squared, low, high))


def solve_transient_flow(problem: TransientProblem, output_times_s, settings: TransientSettings = TransientSettings()
                         ) -> TransientSolution:
    """The flow of ``problem`` from t = 0 to the last of ``output_times_s`` (module doc), its state saved
    at t = 0 and at each of those times; ValueError when a step cut below ``settings.min_step_s`` still
    does not converge."""
    times = np.unique(np.asarray(output_times_s, dtype=float).ravel())
    if times.size == 0 or not np.all(np.isfinite(times)) or times[0] <= 0.0:
        raise ValueError(f"{WHO}: the output times must be finite and > 0")
    solver = _Solver(problem, settings)
    n, n_bound = problem.node_xy_m.shape[0], len(problem.boundaries)
    y = solver.y
    psi = np.asarray(problem.initial_head_m, dtype=float) - y
    if psi.shape != (n,) or not np.all(np.isfinite(psi)):
        raise ValueError(f"{WHO}: initial_head_m must give every one of the {n} nodes a finite head")
    water, _, storage, saturation, kr = solver.materials.state(psi)
    _, may_hold, _, _ = solver.conditions.at(0.0, times[0])
    held = may_hold & (psi >= 0.0)
    dry = np.zeros(n, dtype=bool)
    for boundary, mine in zip(problem.boundaries, solver.conditions.mine):
        if isinstance(boundary, FluxBoundary) and boundary.dry_limit_m is not None and np.any(
                boundary.flux_m_s.values < 0.0) and np.any(psi[mine] < boundary.dry_limit_m - settings.head_tolerance_m):
            raise ValueError(f"{WHO}: boundary {boundary.name!r}: its initial pressure head is down to "
                             f"{psi[mine].min():.4g} m, below its dry limit {boundary.dry_limit_m:g} m (holding it "
                             "there would wet the ground)")
    events = np.unique(np.concatenate([times, solver.conditions.breakpoints_s()]))
    events = events[(events > 0.0) & (events <= times[-1])]
    owner = solver.conditions.owner

    saved: dict[str, list] = {key: [] for key in ("head", "theta", "se", "v", "held", "rate", "cum", "in", "out", "stored", "err")}
    cumulative, rate = np.zeros(n_bound), np.zeros(n_bound)
    water_in = water_out = storage_term = error = 0.0

    def save(psi, water, saturation, kr, held):
        h = psi + y
        saved["head"].append(h)
        saved["theta"].append(water / solver.lumped)
        saved["se"].append(saturation / solver.lumped)
        saved["v"].append(darcy_velocity_m_s(kr, problem.elem_conductivity_m_s, solver.system.b, h[problem.elem_nodes]))
        saved["held"].append(held.copy())
        saved["rate"].append(rate.copy())
        saved["cum"].append(cumulative.copy())
        saved["in"].append(water_in)
        saved["out"].append(water_out)
        saved["stored"].append(float(np.sum(water)) + storage_term)
        saved["err"].append(error)

    save(psi, water, saturation, kr, held)
    log: dict[str, list] = {key: [] for key in ("end", "dt", "it", "err", "scale")}
    rejected = 0
    t, dt = 0.0, min(max(settings.initial_step_s, settings.min_step_s), settings.max_step_s)
    next_save = 0
    last_rate = None
    while next_save < times.size:
        next_event = events[np.searchsorted(events, t, side="right")]
        remaining = next_event - t
        step = remaining if remaining <= dt else 0.5 * remaining if remaining < 2.0 * dt else dt  # no sliver
        guess = psi if last_rate is None else psi + step * last_rate  # the last step's trend continued
        done = solver.step(psi, water, held, dry, t, step, guess)
        if done is None:
            rejected += 1
            dt = step * settings.cut
            if dt < settings.min_step_s:
                raise FlowNotConverged(f"{WHO}: the iteration does not converge at t = {t:.6g} s even with a step of "
                                 f"{step:.3g} s (min_step_s = {settings.min_step_s:g} s)")
            continue
        rate = np.bincount(owner[owner >= 0], weights=done.node_inflow[owner >= 0], minlength=n_bound).astype(float)
        cumulative = cumulative + rate * step
        water_in += step * float(np.sum(np.maximum(done.node_inflow, 0.0)))
        water_out += step * float(np.sum(np.maximum(-done.node_inflow, 0.0)))
        step_storage = float(np.sum(done.storage * (done.psi - psi - done.load_change_m)))
        storage_term += step_storage
        step_error = float(np.sum(rate) * step - (np.sum(done.water) - np.sum(water) + step_storage))
        error += step_error
        for key, value in zip(("end", "dt", "it", "err", "scale"),
                              (t + step, step, done.iterations, step_error, done.scale_m2)):
            log[key].append(value)
        t = next_event if step == remaining else t + step
        last_rate = (done.psi - psi) / step
        psi, water, held, dry = done.psi, done.water, done.held, done.dry
        if done.iterations > settings.hard_iterations:
            dt = max(settings.min_step_s, min(dt, step) * settings.shrink)
        elif done.iterations <= settings.easy_iterations and step == dt:  # a step shortened to an event says little
            dt = min(settings.max_step_s, dt * settings.growth)
        while next_save < times.size and t >= times[next_save]:
            save(psi, water, done.saturation, done.kr, held | dry)
            next_save += 1

    return TransientSolution(
        times_s=np.concatenate([[0.0], times]), head_m=np.array(saved["head"]), water_content=np.array(saved["theta"]),
        effective_saturation=np.array(saved["se"]), elem_darcy_velocity_m_s=np.array(saved["v"]),
        node_held=np.array(saved["held"]), boundary_names=tuple(b.name for b in problem.boundaries),
        boundary_inflow_m2_s=np.array(saved["rate"]).reshape(len(saved["rate"]), n_bound),
        boundary_cumulative_inflow_m2=np.array(saved["cum"]).reshape(len(saved["cum"]), n_bound),
        water_in_m2=np.array(saved["in"]), water_out_m2=np.array(saved["out"]),
        stored_water_m2=np.array(saved["stored"]), balance_error_m2=np.array(saved["err"]),
        step_end_s=np.array(log["end"]), step_s=np.array(log["dt"]), step_iterations=np.array(log["it"], dtype=int),
        step_balance_error_m2=np.array(log["err"]), step_balance_scale_m2=np.array(log["scale"]),
        rejected_steps=rejected, solves=solver.solves, factorizations=solver.factorizations)
