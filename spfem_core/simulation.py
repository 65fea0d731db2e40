"""A simulation owns the particle state and drives the compiled time loop.

Python decides only what happens between compiled calls: when to check or rebuild the
mesh, when to grow the record buffers, when to report progress and when to stop.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.mesh import Mesh, element_quality_min_angle, triangulate
from spfem_core.scene import MaterialTable, Scene, SolverSettings
from spfem_core.smoothing import ELEM_GEOM_WIDTH, smooth_velocity_gradient
from spfem_core.stepper import (
    ACC_ANGLE_BUDGET,
    ACC_ANGLE_USED,
    ACC_MESH_CHECKS,
    ACC_CONTACT_WORK,
    ACC_CONTACTS,
    ACC_DAMPING_WORK,
    ACC_LAST_MAX_SPEED,
    ACC_LAST_RATIO,
    ACC_NEXT_RECORD,
    ACC_PLASTIC_WORK,
    ACC_STAB_WORK,
    ACC_WIDTH,
    ENERGY_COLUMNS,
    STATUS_BUFFER_FULL,
    STATUS_CONVERGED,
    STATUS_DONE,
    STATUS_INVERTED,
    STATUS_MESH_CHECK,
    STATUS_NOT_FINITE,
    STATUS_RUNAWAY,
    STEP_OUT_WIDTH,
    advance,
    empty_records,
    record_state,
)
from spfem_core.timestep import critical_time_step

WALL_SECONDS_PER_CALL = 0.25
"""Target wall time of one compiled call (sets how often progress is reported)."""

STOP_CHECK_FRACTION = 0.02
"""With a stop rule, it is asked every this fraction of the stage's duration (simulated time)."""

ANGLE_MARGIN_RAD = math.radians(1.0)
"""Safety margin on the cheap angle bound (it uses the strain rate of the previous step)."""

ENERGY_CREATED_LIMIT = 0.25
"""Divergence when kinetic + strain + gravity potential + dissipated energy has grown since
the stage start by more than this fraction of the largest energy scale (kinetic + strain +
|potential|) seen so far: a stable run only loses energy (about 1-2% leapfrog wobble)."""

ANGLE_THRESHOLD_DROP_RAD = math.radians(5.0)
"""Adaptive remesh threshold: after a rebuild whose smallest angle is theta, the next rebuild
comes when the smallest angle falls below min(settings.min_angle_deg, max(theta - 5 deg,
theta / 2)).  ESPFEM2D clamps at 5 deg instead of theta / 2; a fresh Delaunay mesh of a
disordered cloud is often only 8-10 deg at its worst element, which left a 3-5 deg budget
and a rebuild every few dozen steps."""

DT_COLLAPSE_FACTOR = 1e-3
"""Divergence when remeshing would cut the time step below this fraction of the stage's
first time step: the mesh has degenerated (particles piling onto each other)."""


def max_stable_cfl(beta: float) -> float:
    """Largest accepted cfl for stabilisation ``beta``: 1 / (1 + beta).

    The stabilisation is a bond viscosity proportional to beta dt, so it lowers the stable
    step.  Measured by ``benchmarks/stability_limit.py`` on the beam lattice: limits 1.51,
    1.46, 1.32, 0.94 for beta = 0, 0.1, 0.3, 1 (jittered cloud: 1.68, 1.57, 1.38, 0.80);
    the rule keeps a margin of at least 1.5 on all of them.
    """
    return 1.0 / (1.0 + max(beta, 0.0))


StopRule = Callable[[np.ndarray, np.ndarray, np.ndarray], "str | None"]
"""Asked between compiled calls with the records so far (time_s, max_displacement_m,
kinetic_energy_j_per_m; read-only views): a reason (one line) to end the stage now, or None."""


Snapshot = tuple[float, Callable[[float], None]]
"""(interval in s, callback(stage time in s)): the callback reads the state from the simulation."""


class DivergenceError(RuntimeError):
    """The solution blew up; ``step`` and ``time_s`` say where, ``partial`` holds the records so far."""

    def __init__(self, reason: str, step: int, time_s: float, partial: "TimeSeries | None" = None):
        super().__init__(f"run diverged at step {step} (t = {time_s:.6g} s): {reason}")
        self.reason = reason
        self.step = step
        self.time_s = time_s
        self.partial = partial


class UnstableTimeStepError(ValueError):
    """A requested time step above the critical step of the explicit scheme."""


def _neighbour_sums(node_xy: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per node, the sum of the positions of its neighbours along ``edges`` (m, 2) and their number
    (each edge (i, j) given once)."""
    sums = np.zeros_like(node_xy)
    degree = np.zeros(node_xy.shape[0])
    for a, b in ((0, 1), (1, 0)):
        np.add.at(sums, edges[:, a], node_xy[edges[:, b]])
        np.add.at(degree, edges[:, a], 1.0)
    return sums, degree


class _MeshCollapse(Exception):
    """Raised by a remesh that would stall the run; turned into DivergenceError by the stage."""


@dataclass
class TimeSeries:
    """What a stage recorded: one row per record time (stage time, seconds from its start)."""

    time_s: np.ndarray  # (n_rec,)
    monitor_displacement_m: np.ndarray  # (n_rec, n_monitor, 2)
    monitor_velocity_m_s: np.ndarray  # (n_rec, n_monitor, 2)
    monitor_stress_pa: np.ndarray  # (n_rec, n_monitor, 4) xx, yy, zz, xy
    energy_j_per_m: np.ndarray  # (n_rec, 5) columns ENERGY_COLUMNS
    max_displacement_m: np.ndarray  # (n_rec,)
    dt_s: float
    n_steps: int
    n_remesh: int
    n_mesh_checks: int
    wall_time_s: float
    converged: bool | None = None  # relaxation only
    unbalanced_force_ratio: float = math.nan  # at the last step
    notes: dict = field(default_factory=dict)

    energy_columns = ENERGY_COLUMNS

    @property
    def kinetic_energy_j_per_m(self) -> np.ndarray:
        return self.energy_j_per_m[:, 0]


@dataclass
class _Records:
    """Growable record buffers shared with the kernel."""

    n_monitor: int
    capacity: int
    count: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))

    def __post_init__(self):
        self.arrays = list(empty_records(self.capacity, self.n_monitor))

    def grow(self):
        new = empty_records(2 * self.capacity, self.n_monitor)
        for old_array, new_array in zip(self.arrays, new):
            new_array[: self.capacity] = old_array
        self.arrays = list(new)
        self.capacity *= 2

    def trimmed(self):
        n = int(self.count[0])
        return [a[:n].copy() for a in self.arrays]


class Simulation:
    """Particle state of a scene and the stages run on it.

    State (SI units): ``node_xy_m`` current positions, ``node_displacement_m`` since the
    stage started, ``node_velocity_m_s`` (leapfrog half-step velocity), ``node_stress_pa``
    (xx, yy, zz, xy), ``node_mass_kg`` (fixed at the start: m_k = rho_k A_k on the first mesh).
    """

    def __init__(self, scene: Scene, settings: SolverSettings | None = None, allow_detached: bool = False):
        """``allow_detached``: accept particles in no triangle of the first mesh (they fly under
        gravity with the nominal mass rho h^2 until they land); otherwise such a cloud is an error."""
        self.scene = scene
        self.settings = settings or SolverSettings()
        n = scene.n_particles
        self.node_initial_xy_m = scene.node_xy_m.copy()
        self.node_xy_m = scene.node_xy_m.copy()
        self.node_displacement_m = np.zeros((n, 2))
        self.node_velocity_m_s = np.zeros((n, 2))
        self.node_stress_pa = np.zeros((n, 4))
        self.node_plastic_strain = np.zeros(n)  # equivalent plastic strain, sum of sqrt(2/3 de_p:de_p)
        self.node_material = scene.node_material
        self.node_fixed = scene.node_fixed.copy()
        self.node_fixed_velocity_m_s = scene.node_fixed_velocity_m_s.copy()
        self._set_material_arrays(scene.materials)

        self._node_L = np.zeros((n, 4))
        self._node_area = np.zeros(n)
        self._node_force = np.zeros((n, 2))
        self._node_contact = np.zeros(n, dtype=np.int64)
        self._step_out = np.zeros(STEP_OUT_WIDTH)
        self._acc = np.zeros(ACC_WIDTH)
        self.n_orphans = 0
        self._rejoin_tried_xy = None  # detached positions at the last rejoin rebuild that took none in
        mats = scene.materials

        self.mesh = self._build_mesh()
        self._initial_mesh = self.mesh
        orphans = self.mesh.orphan_nodes
        if orphans.size and not allow_detached:
            raise ValueError(
                f"{orphans.size} particles lie in no triangle of the initial mesh (first: {orphans[:5].tolist()}); "
                "check the spacing against the geometry or raise alpha"
            )
        cell_area = self._node_area.copy()
        cell_area[orphans] = scene.spacing_m**2
        self.node_mass_kg = mats.density_kg_m3[self.node_material] * cell_area
        self.n_orphans = int(orphans.size)
        self.total_mass_kg = float(self.node_mass_kg.sum())

        self._choose_time_step()
        self.n_steps_total = 0
        self.n_remesh_total = 0
        self.n_smoothed_total = 0
        self.remesh_wall_s = 0.0  # wall time spent rebuilding meshes (all stages)
        self._relaxing = False  # True inside relax(): steps at the largest accepted cfl
        self._angle_threshold_rad = math.radians(self.settings.min_angle_deg)
        self._reset_angle_budget(after_rebuild=True)

    def _choose_time_step(self):
        """dt from the cfl or the given dt_s, checked against the stable limit (see module doc)."""
        self.critical_dt_s = self._critical_dt()
        self.max_cfl = max_stable_cfl(self.settings.stabilisation_beta)
        if self.settings.dt_s is not None:
            limit = self.max_cfl * self.critical_dt_s
            if not 0.0 < self.settings.dt_s <= limit:
                raise UnstableTimeStepError(
                    f"dt_s = {self.settings.dt_s:.4g} s is above the stable time step {limit:.4g} s "
                    f"(2 / the bound on the highest frequency of the mesh, spfem_core.timestep, "
                    f"times {self.max_cfl:.3g} for beta = {self.settings.stabilisation_beta:g}); "
                    f"use dt_s <= {limit:.4g} or set cfl instead"
                )
            self.dt_s = float(self.settings.dt_s)
        else:
            if not 0.0 < self.settings.cfl <= self.max_cfl:
                raise UnstableTimeStepError(
                    f"cfl = {self.settings.cfl:g} is outside (0, {self.max_cfl:.3g}], the stable range for "
                    f"beta = {self.settings.stabilisation_beta:g} (limit 1 / (1 + beta))"
                )
            self.dt_s = self.settings.cfl * self.critical_dt_s
        self._stage_first_dt_s = self.dt_s  # a stage sets it again when it starts

    # ------------------------------------------------------------------ mesh
    def _build_mesh(self) -> Mesh:
        mesh = triangulate(self.node_xy_m, self.scene.spacing_m, self.scene.alpha)
        self._elem_geom = np.zeros((mesh.n_elem, ELEM_GEOM_WIDTH))
        smooth_velocity_gradient(
            self.node_xy_m, self.node_velocity_m_s, mesh.elem_nodes, self._elem_geom, self._node_L, self._node_area
        )
        return mesh

    def _critical_dt(self) -> float:
        mesh = self.mesh
        return float(critical_time_step(
            self.node_xy_m, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, self.node_mass_kg,
            self.node_material, self._mat_lambda, self._mat_shear,
        ))

    def _set_material_arrays(self, materials: MaterialTable):
        self.materials = materials
        self._mat_model = materials.model
        self._mat_youngs = materials.youngs_modulus_pa
        self._mat_poisson = materials.poisson_ratio
        self._mat_shear = materials.shear_modulus_pa
        self._mat_lambda = materials.lame_lambda_pa
        self._mat_params = materials.model_params()
        self._node_wave_speed = materials.p_wave_speed_m_s[self.node_material]
        self.speed_limit_m_s = float(self._node_wave_speed.max())

    def set_materials(self, materials: MaterialTable):
        """Use another material table from now on (same rows; e.g. elastic gravity stage, reduced
        strength).  The time step is chosen again for the new wave speeds."""
        if materials.n_materials != self.materials.n_materials:
            raise ValueError(f"materials: expected {self.materials.n_materials} rows, got {materials.n_materials}")
        self._set_material_arrays(materials)
        self._choose_time_step()

    def set_supports(self, node_fixed: np.ndarray, node_fixed_velocity_m_s: np.ndarray):
        """Prescribed velocities from now on (e.g. release a retaining side for a collapse)."""
        self.node_fixed = np.ascontiguousarray(node_fixed, dtype=bool).reshape(self.n_particles, 2)
        self.node_fixed_velocity_m_s = np.ascontiguousarray(node_fixed_velocity_m_s, dtype=np.float64).reshape(
            self.n_particles, 2
        )

    def _reset_angle_budget(self, after_rebuild: bool = False):
        """Exact smallest angle now; the loop may run until the cheap bound could reach the threshold.

        After a rebuild the threshold adapts (see ANGLE_THRESHOLD_DROP_RAD).
        """
        min_angle = float(element_quality_min_angle(self.node_xy_m, self.mesh.elem_nodes))
        self.min_angle_rad = min_angle
        if after_rebuild:
            ceiling = math.radians(self.settings.min_angle_deg)
            self._angle_threshold_rad = min(max(min_angle - ANGLE_THRESHOLD_DROP_RAD, 0.5 * min_angle), ceiling)
        self._acc[ACC_ANGLE_USED] = 0.0
        self._acc[ACC_ANGLE_BUDGET] = max(min_angle - self._angle_threshold_rad - ANGLE_MARGIN_RAD, 0.0)

    def _smooth_crowded_particles(self) -> int:
        """One Laplacian pass over the free particles whose nearest mesh neighbour is closer than
        crowded_fraction * h: an interior particle moves to the mean of its mesh neighbours, a
        boundary particle (on an edge of one triangle) to the mean of its neighbours along the
        boundary, so that it slides along the free surface or a floor instead of leaving it.
        The displacement moves with the position (u += delta x), so u stays x - x0.  Returns the
        number of particles moved.

        Boundary particles used to be left alone.  On the granular collapse at h = 1 mm the
        particles at the flow front, pressed onto the floor, closed up pairwise (with the
        element time-step rule of the time, the triangles between them cut the step 500-fold;
        the bound of ``spfem_core.timestep`` is not fooled by such pairs, but crowded
        particles still make poor smoothing cells).
        """
        mesh = self.mesh
        xy = self.node_xy_m
        n = self.n_particles
        edges = mesh.edge_nodes
        if edges.shape[0] == 0:
            return 0
        length = np.hypot(*(xy[edges[:, 1]] - xy[edges[:, 0]]).T)
        nearest = np.full(n, np.inf)
        np.minimum.at(nearest, edges[:, 0], length)
        np.minimum.at(nearest, edges[:, 1], length)
        crowded = nearest < self.settings.crowded_fraction * self.scene.spacing_m
        movable = crowded & ~self.node_fixed.any(axis=1)
        if not movable.any():
            return 0
        # boundary edges: sides of a single triangle
        tri = mesh.elem_nodes
        side = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        unique, count = np.unique(side[:, 0] * n + side[:, 1], return_counts=True)
        boundary_edges = np.stack([unique[count == 1] // n, unique[count == 1] % n], axis=1)
        on_boundary = np.zeros(n, dtype=bool)
        on_boundary[boundary_edges.ravel()] = True
        # interior particles average over all their mesh neighbours, boundary ones over their
        # neighbours along the boundary
        sums, degree = _neighbour_sums(xy, edges)
        boundary_sums, boundary_degree = _neighbour_sums(xy, boundary_edges)
        sums[on_boundary] = boundary_sums[on_boundary]
        degree[on_boundary] = boundary_degree[on_boundary]
        nodes = np.flatnonzero(movable & (degree > 0))
        if nodes.size == 0:
            return 0
        target = sums[nodes] / degree[nodes, None]
        delta = target - xy[nodes]
        self.node_xy_m[nodes] = target
        self.node_displacement_m[nodes] += delta
        return int(nodes.size)

    def _remesh(self):
        start = time.perf_counter()
        try:
            self._rebuild()
        finally:
            self.remesh_wall_s += time.perf_counter() - start

    def _rebuild(self):
        """Spread crowded particles, then triangulate once.

        The crowded particles are found on the outgoing mesh (it still joins every particle
        to its near neighbours; it has only lost quality).  Smoothing after the new Delaunay
        meant a second one whenever a particle moved, a third of all rebuilds of the granular
        collapse, and Qhull is three quarters of a rebuild's cost.
        """
        moved = self._smooth_crowded_particles()
        self.n_smoothed_total += moved
        self.mesh = self._build_mesh()
        self.n_remesh_total += 1
        self.n_orphans = int(self.mesh.orphan_nodes.size)
        self._reset_angle_budget(after_rebuild=True)
        critical = self._critical_dt()
        self.critical_dt_s = critical
        # dt follows the new mesh both ways: a fixed dt_s is kept while stable, a cfl is re-applied
        if self._relaxing:
            new_dt = self.max_cfl * critical  # see relax()
        elif self.settings.dt_s is not None and self.settings.dt_s <= self.max_cfl * critical:
            new_dt = float(self.settings.dt_s)
        else:
            new_dt = min(self.settings.cfl, self.max_cfl) * critical
        if new_dt < DT_COLLAPSE_FACTOR * self._stage_first_dt_s:
            raise _MeshCollapse(
                f"the mesh degenerated: its critical time step fell to {critical:.3g} s "
                f"(the stage started with dt = {self._stage_first_dt_s:.3g} s)"
            )
        self.dt_s = new_dt

    def _orphans_can_rejoin(self) -> bool:
        """True when a particle outside the mesh has come within h of a meshed particle (closer
        than that the alpha shape takes it in; further, a rebuild would leave it out again)."""
        orphans = self.mesh.orphan_nodes
        if orphans.size == 0:
            return False
        tried = self._rejoin_tried_xy
        if tried is not None and tried.shape == (orphans.size, 2):
            # the last rebuild left them out: try again only once one has moved h/2
            moved = np.hypot(*(self.node_xy_m[orphans] - tried).T).max()
            if moved < 0.5 * self.scene.spacing_m:
                return False
        self._rejoin_tried_xy = self.node_xy_m[orphans].copy()

        meshed = np.ones(self.n_particles, dtype=bool)
        meshed[orphans] = False
        tree = cKDTree(self.node_xy_m[meshed])
        distance, _ = tree.query(self.node_xy_m[orphans], k=1)
        return bool(np.any(distance < self.scene.spacing_m))

    def discard_displacement(self):
        """Back to the initial positions and mesh, at rest, keeping the stresses (stage change)."""
        self.node_xy_m[:] = self.node_initial_xy_m
        self.node_displacement_m[:] = 0.0
        self.node_velocity_m_s[:] = 0.0
        self.mesh = self._initial_mesh
        self.n_orphans = 0
        self._elem_geom = np.zeros((self.mesh.n_elem, ELEM_GEOM_WIDTH))
        smooth_velocity_gradient(
            self.node_xy_m, self.node_velocity_m_s, self.mesh.elem_nodes, self._elem_geom, self._node_L, self._node_area
        )
        self._choose_time_step()
        self._reset_angle_budget(after_rebuild=True)

    def set_initial_stress(self, node_stress_pa: np.ndarray, node_plastic_strain: np.ndarray | None = None):
        """Start from a stress state computed elsewhere (a cached gravity stage), at the initial
        positions and at rest: ``node_stress_pa`` (n, 4) xx, yy, zz, xy; plastic strain (n,)."""
        stress = np.asarray(node_stress_pa, dtype=np.float64)
        if stress.shape != (self.n_particles, 4) or not np.all(np.isfinite(stress)):
            raise ValueError(f"node_stress_pa: expected finite ({self.n_particles}, 4), got shape {stress.shape}")
        self.discard_displacement()
        self.node_stress_pa[:] = stress
        if node_plastic_strain is not None:
            plastic = np.asarray(node_plastic_strain, dtype=np.float64).reshape(-1)
            if plastic.shape != (self.n_particles,):
                raise ValueError(f"node_plastic_strain: expected ({self.n_particles},), got shape {plastic.shape}")
            self.node_plastic_strain[:] = plastic

    # ------------------------------------------------------------------ stages
    def run(
        self,
        duration_s: float,
        damping: float = 0.0,
        record_interval_s: float | None = None,
        monitor_nodes=(),
        progress: Callable[[float], None] | None = None,
        stop: StopRule | None = None,
        snapshot: Snapshot | None = None,
    ) -> TimeSeries:
        """Dynamic stage: ``duration_s`` of explicit steps with local damping ``damping``.

        ``stop`` is asked between compiled calls whether the outcome is decided (see
        :data:`StopRule`); the stage then ends early and its notes say why.  ``snapshot``
        (interval in s, callback) is called with the stage time at its start, every interval
        and at its end, with the state of that moment in this object.
        """
        return self._stage(duration_s, damping, 0.0, record_interval_s, monitor_nodes, progress, stop, snapshot)

    def relax(
        self,
        damping: float = 0.7,
        tolerance: float = 1e-4,
        max_duration_s: float = 10.0,
        record_interval_s: float | None = None,
        monitor_nodes=(),
        progress: Callable[[float], None] | None = None,
        snapshot: Snapshot | None = None,
    ) -> TimeSeries:
        """Dynamic relaxation: locally damped steps until |f_unbalanced| / |m g| < ``tolerance``.

        The ratio is over the free directions of all particles (2-norms).  Stops at
        ``max_duration_s`` otherwise, with ``converged = False``.

        Only the end state of a relaxation counts, not its path, so it steps at the largest
        accepted cfl, 1 / (1 + beta), whatever the solver's cfl or dt_s (the dynamic stages
        keep those).  On the reference slope: 2,758 steps instead of 4,938 at cfl 0.5, with
        the relaxed stresses equal within 3.4e-6 of their largest value (tolerance 1e-5).
        ``max_duration_s`` is pseudo-time at that step.
        """
        if not tolerance > 0.0:
            raise ValueError(f"tolerance must be > 0, got {tolerance}")
        self._relaxing = True
        self.dt_s = self.max_cfl * self.critical_dt_s
        try:
            return self._stage(max_duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, None,
                               snapshot)
        finally:
            self._relaxing = False
            self._choose_time_step()

    def _stage(self, duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, stop=None,
               snapshot=None):
        if not duration_s > 0.0:
            raise ValueError(f"duration_s must be > 0, got {duration_s}")
        if not 0.0 <= damping < 1.0:
            raise ValueError(f"damping must be in [0, 1), got {damping}")
        start_wall = time.perf_counter()
        monitor_nodes = np.ascontiguousarray(monitor_nodes, dtype=np.int64).reshape(-1)
        interval = float(record_interval_s) if record_interval_s else max(duration_s / 1000.0, self.dt_s)
        records = _Records(monitor_nodes.size, capacity=int(min(duration_s / interval, 1e6)) + 2)
        self._acc[ACC_NEXT_RECORD] = interval
        for slot in (ACC_DAMPING_WORK, ACC_STAB_WORK, ACC_PLASTIC_WORK, ACC_CONTACT_WORK):
            self._acc[slot] = 0.0  # dissipation is recorded since the stage start
        self._record(records, 0.0, monitor_nodes)

        beta = float(self.settings.stabilisation_beta)
        self._stage_first_dt_s = self.dt_s
        check_energy = not np.any(self.node_fixed_velocity_m_s[self.node_fixed] != 0.0)
        self._stage_smoothed_start = self.n_smoothed_total
        self._stage_remesh_wall_start = self.remesh_wall_s
        energy_checked = 0
        energy_scale = 0.0
        energy_start = float(records.arrays[4][0].sum())
        stage_time = 0.0
        n_steps = 0
        n_remesh_start = self.n_remesh_total
        checks_start = self._acc[ACC_MESH_CHECKS]
        n_checks = 0
        converged = None if tolerance == 0.0 else False
        stop_reason = ""
        # 0.1 us per particle-step is a fair first guess; adapt the chunk to the measured speed
        steps_per_call = max(10, int(WALL_SECONDS_PER_CALL / (1e-7 * max(self.scene.n_particles, 1))))
        if snapshot is not None:
            snapshot_interval, take_snapshot = float(snapshot[0]), snapshot[1]
            take_snapshot(0.0)
            last_snapshot, next_snapshot = 0.0, snapshot_interval
        # The calls' length follows the wall clock (WALL_SECONDS_PER_CALL), so nothing that changes
        # the state may happen at an arbitrary call boundary: the stop rule and the landing checks
        # of detached particles run on schedules of their own (stage time, stage steps), and a
        # run is the same on a fast or a slow machine.
        stop_every_s = STOP_CHECK_FRACTION * duration_s
        next_stop_s = stop_every_s
        next_landing_check = -1  # stage step of the next landing check (-1: none scheduled)
        while stage_time < duration_s - 0.5 * self.dt_s:
            n_want = min(steps_per_call, max(1, int(round((duration_s - stage_time) / self.dt_s))))
            if snapshot is not None:  # end the call at the next snapshot time
                n_want = min(n_want, max(1, int(math.ceil((next_snapshot - stage_time) / self.dt_s - 1e-9))))
            if stop is not None:  # ask the stop rule every STOP_CHECK_FRACTION of the stage
                n_want = min(n_want, max(1, int(math.ceil((next_stop_s - stage_time) / self.dt_s - 1e-9))))
            if not self.n_orphans:
                next_landing_check = -1
            elif next_landing_check < 0:
                # a detached particle must be seen before it crosses the mesh: check for landing
                # after half a spacing of travel of the fastest particle
                speed = max(float(np.abs(self.node_velocity_m_s).max()), 1e-12)
                next_landing_check = n_steps + max(1, int(0.5 * self.scene.spacing_m / (speed * self.dt_s)))
            if next_landing_check >= 0:
                n_want = max(1, min(n_want, next_landing_check - n_steps))
            call_start = time.perf_counter()
            status, done = advance(
                self.node_xy_m, self.node_displacement_m, self.node_velocity_m_s, self.node_stress_pa,
                self.node_plastic_strain, self.node_mass_kg, self.node_material, self.node_fixed,
                self.node_fixed_velocity_m_s,
                self._node_L, self._node_area, self._node_force, self._elem_geom, self._step_out, self._node_contact,
                self.mesh.elem_nodes, self.mesh.edge_nodes,
                self._mat_model, self._mat_lambda, self._mat_shear, self._mat_youngs, self._mat_poisson,
                self._mat_params,
                self.scene.wall_xy_m, self.scene.wall_friction, self.scene.spacing_m,
                self.scene.gravity_m_s2, self.dt_s, float(damping), beta, self.speed_limit_m_s, float(tolerance),
                self._angle_threshold_rad, ANGLE_MARGIN_RAD,
                n_want, stage_time,
                interval, monitor_nodes, records.count, *records.arrays,
                self._acc,
            )
            elapsed = time.perf_counter() - call_start
            stage_time += done * self.dt_s
            n_checks = int(self._acc[ACC_MESH_CHECKS] - checks_start)
            n_steps += done
            self.n_steps_total += done
            if done >= 10 and elapsed > 0:
                steps_per_call = max(10, int(done * WALL_SECONDS_PER_CALL / elapsed))
            reason = None
            if status in (STATUS_NOT_FINITE, STATUS_RUNAWAY):
                reason = (
                    "velocity is not finite"
                    if status == STATUS_NOT_FINITE
                    else f"a particle moves at {self._acc[ACC_LAST_MAX_SPEED]:.4g} m/s, faster than the "
                    f"P-wave speed {self.speed_limit_m_s:.4g} m/s (runaway kinetic energy)"
                )
            elif check_energy:
                energy = records.arrays[4]
                for row in range(energy_checked, int(records.count[0])):
                    kinetic, strain, potential = energy[row, 0], energy[row, 1], energy[row, 2]
                    energy_scale = max(energy_scale, kinetic + strain + abs(potential))
                    created = float(energy[row].sum()) - energy_start
                    if not created <= ENERGY_CREATED_LIMIT * energy_scale:  # NaN too
                        reason = (
                            f"the run created energy: {created:.4g} J/m at t = {records.arrays[0][row]:.6g} s, "
                            f"more than {ENERGY_CREATED_LIMIT:g} of the energy scale {energy_scale:.4g} J/m"
                        )
                        break
                energy_checked = int(records.count[0])
            if reason is not None:
                partial = self._series(records, n_steps, n_remesh_start, n_checks, start_wall, converged, beta)
                raise DivergenceError(reason, self.n_steps_total, stage_time, partial)
            try:
                if status == STATUS_INVERTED:
                    self._remesh()
                elif status == STATUS_MESH_CHECK:
                    self._remesh()
                elif 0 <= next_landing_check <= n_steps:
                    next_landing_check = -1  # the next one is scheduled from the state after this one
                    if self.n_orphans and self._orphans_can_rejoin():
                        self._remesh()
            except _MeshCollapse as collapse:
                partial = self._series(records, n_steps, n_remesh_start, n_checks, start_wall, converged, beta)
                raise DivergenceError(str(collapse), self.n_steps_total, stage_time, partial) from None
            if status == STATUS_BUFFER_FULL:
                records.grow()
            elif status == STATUS_CONVERGED:
                converged = True
                break
            elif status not in (STATUS_DONE, STATUS_MESH_CHECK, STATUS_INVERTED):
                raise RuntimeError(f"unknown status {status} from the time loop")
            if stop is not None and stage_time >= next_stop_s - 0.5 * self.dt_s:
                while next_stop_s <= stage_time + 0.5 * self.dt_s:
                    next_stop_s += stop_every_s
                n_rec = int(records.count[0])
                arrays = records.arrays
                early = stop(arrays[0][:n_rec], arrays[5][:n_rec], arrays[4][:n_rec, 0])
                if early:
                    stop_reason = str(early)
                    break
            if snapshot is not None and stage_time >= next_snapshot - 0.5 * self.dt_s:
                take_snapshot(stage_time)
                last_snapshot = stage_time
                while next_snapshot <= stage_time + 0.5 * self.dt_s:
                    next_snapshot += snapshot_interval
            if progress is not None:
                progress(min(stage_time / duration_s, 1.0))
        if snapshot is not None and stage_time > last_snapshot + 0.5 * self.dt_s:
            take_snapshot(stage_time)  # the end, unless it was a snapshot time already
        if records.arrays[0][int(records.count[0]) - 1] < stage_time - 1e-12 * max(stage_time, 1.0):
            if int(records.count[0]) >= records.capacity:
                records.grow()
            self._record(records, stage_time, monitor_nodes)
        if progress is not None:
            progress(1.0)
        series = self._series(records, n_steps, n_remesh_start, n_checks, start_wall, converged, beta)
        if stop_reason:
            series.notes["early_stop"] = f"stopped at t = {series.time_s[-1]:.4g} s of {duration_s:g} s: {stop_reason}"
        return series

    def _record(self, records: _Records, time_s: float, monitor_nodes: np.ndarray):
        slot = int(records.count[0])
        record_state(
            slot, time_s, self.node_displacement_m, self.node_velocity_m_s, self.node_stress_pa, self.node_mass_kg,
            self._node_area, self.node_material, self._mat_youngs, self._mat_poisson, self.scene.gravity_m_s2,
            monitor_nodes, self._acc, *records.arrays,
        )
        records.count[0] = slot + 1

    def _series(self, records, n_steps, n_remesh_start, n_checks, start_wall, converged, beta) -> TimeSeries:
        time_s, u, v, stress, energy, max_u = records.trimmed()
        n_remesh = self.n_remesh_total - n_remesh_start
        n_walls = self.scene.wall_xy_m.shape[0]
        plastic = bool(np.any(self._mat_model != 0))
        notes = {
            "stabilisation": f"on (beta = {beta:g})" if beta > 0 else "off (beta = 0): bond loop skipped",
            "contact": (
                f"on ({n_walls} walls, {int(self._acc[ACC_CONTACTS])} particles touching at the end)"
                if n_walls
                else "off (no walls): contact loop skipped"
            ),
            "remesh": (
                f"{n_remesh} rebuilds and {n_checks} exact quality checks in {n_steps} steps; "
                f"{self.n_smoothed_total - self._stage_smoothed_start} crowded particles smoothed; "
                f"{self.remesh_wall_s - self._stage_remesh_wall_start:.2f} s rebuilding"
            ),
            "plasticity": "on" if plastic else "off (all materials elastic)",
            "particles_outside_mesh": f"{self.n_orphans} at the end",
        }
        if converged is True:
            notes["early_stop"] = f"relaxation converged after {n_steps} steps (t = {time_s[-1]:.4g} s)"
        return TimeSeries(
            time_s=time_s,
            monitor_displacement_m=u,
            monitor_velocity_m_s=v,
            monitor_stress_pa=stress,
            energy_j_per_m=energy,
            max_displacement_m=max_u,
            dt_s=self.dt_s,
            n_steps=n_steps,
            n_remesh=n_remesh,
            n_mesh_checks=n_checks,
            wall_time_s=time.perf_counter() - start_wall,
            converged=converged,
            unbalanced_force_ratio=float(self._acc[ACC_LAST_RATIO]),
            notes=notes,
        )

    @property
    def n_particles(self) -> int:
        return self.scene.n_particles

    @property
    def node_contact(self) -> np.ndarray:
        """1 where a wall acted on the particle in the last step."""
        return self._node_contact.copy()

    @property
    def node_area_m2(self) -> np.ndarray:
        """Smoothing-cell areas A_k on the current mesh (as of the last step)."""
        return self._node_area.copy()
