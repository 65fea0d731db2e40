"""A simulation owns the particle state of a scene and drives the compiled time loop.

Python decides only what happens between compiled calls (``stepper.advance``): when to check
or rebuild the mesh (``remeshing``), which time step to take (``timestep.TimeStepPolicy``),
whether the run has diverged (``divergence``), when to grow the record buffers
(``records``), and when to stop, snapshot or report progress (``schedule``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from spfem_core.divergence import DivergenceError, EnergyWatch, speed_reason
from spfem_core.elastic_solve import ElasticSystem, NotSolvable
from spfem_core.jit import kernel_threads, set_threads
from spfem_core.materials.table import MaterialTable
from spfem_core.mesh import Mesh, boundary_edges
from spfem_core.records import RecordBuffers, TimeSeries, record_state
from spfem_core.remeshing import ANGLE_MARGIN_RAD, Remesher
from spfem_core.scene import Scene
from spfem_core.schedule import StageSchedule
from spfem_core.settings import SolverSettings
from spfem_core.smoothing import smooth_velocity_gradient
from spfem_core.snapshot import Snapshot, StressState
from spfem_core.stage_setup import StageSetup, Supports, body_force_m_s2, pore_pressure_pa, with_load_ramp, with_water
from spfem_core.state import (
    SLIP,
    SLIP_SIDE,
    ExternalLoads,
    MaterialArrays,
    NodeState,
    StepParameters,
    StepScratch,
    Walls,
)
from spfem_core.stepper import (
    LOOP_CONTACTS,
    LOOP_LAST_MAX_SPEED,
    LOOP_LAST_RATIO,
    LOOP_MESH_CHECKS,
    LOOP_NEXT_RECORD,
    STATUS_BUFFER_FULL,
    STATUS_CONVERGED,
    STATUS_DONE,
    STATUS_INVERTED,
    STATUS_MESH_CHECK,
    STATUS_NOT_FINITE,
    STATUS_RUNAWAY,
    advance,
    new_accumulators,
    unbalanced_force_at_rest,
)
from spfem_core.timestep import (
    DT_COLLAPSE_FACTOR,
    TimeStepPolicy,
    cell_frequency_bounds,
    critical_time_step,
    equalised_inertia,
)

SOLVE_MARGIN = 0.1
"""``Simulation.solve_elastic`` solves until the unbalanced-force ratio is below this times the
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

StopRule = Callable[[np.ndarray, np.ndarray, np.ndarray], "str | None"]
"""Asked between compiled calls with the records so far (time_s, max_displacement_m,
energy_j_per_m with the columns of ``energy_budget.ENERGY_COLUMNS``; read-only views): a reason (one
line) to end the stage now, or None."""

SnapshotHook = tuple[float, Callable[[Snapshot], None]]
"""(interval in s, callback(the particles at that moment, a ``snapshot.Snapshot``))."""

PeriodicAction = tuple[float, Callable[[float], None]]
"""(interval in s, callback(stage time in s)) called every interval of stage time, not at the
start or the end: it may change the simulation (a step of a strength ramp: ``set_materials``)."""


class DetachedParticlesError(ValueError):
    """Particles in no triangle of the first mesh (without ``allow_detached``)."""


@dataclass
class RunCounters:
    """Totals over every stage of a simulation."""

    steps: int = 0
    rebuilds: int = 0
    smoothed: int = 0  # crowded particles moved at rebuilds
    remesh_wall_s: float = 0.0  # wall time spent rebuilding meshes


def material_arrays(materials: MaterialTable) -> MaterialArrays:
    """The kernels' view of a material table."""
    return MaterialArrays(materials.model, materials.lame_lambda_pa, materials.shear_modulus_pa,
                          materials.youngs_modulus_pa, materials.poisson_ratio, materials.kernel_constants())


class Simulation:
    """Particle state of a scene and the stages run on it.

    ``nodes`` (``state.NodeState``) holds the state in SI units: current positions, the
    displacement since the particles last left their initial positions (the first stage, or a stage
    that starts from the original positions), the leapfrog half-step velocity, the stress
    (xx, yy, zz, xy), the equivalent plastic strain, the masses fixed at the start
    (m_k = rho_k A_k on the first mesh) and each particle's row of ``particle_materials``, the
    material table of the scene (``Scene.particle_materials``: a row per material, or per particle
    where properties are given per particle).  ``materials`` is the table in use (elastic, reduced).
    Stages start with :meth:`begin_stage`, run with :meth:`run` or :meth:`relax`, and hand out
    :meth:`snapshot` values.
    """

    def __init__(self, scene: Scene, settings: SolverSettings | None = None, allow_detached: bool = False,
                 initial_mesh: Mesh | None = None):
        """``allow_detached``: accept particles in no triangle of the first mesh (they fly under
        gravity with the nominal mass rho h^2 until they land); otherwise such a cloud is an error.
        ``initial_mesh``: the mesh of ``scene.node_xy_m`` as ``Remesher.triangulate`` makes it, when
        the caller has it already (runs of one cloud on one worker; it is never changed in place)."""
        self.scene = scene
        self.settings = settings or SolverSettings()
        self.threads = set_threads(self.settings.threads, scene.n_particles)  # threads of the compiled step
        n = scene.n_particles
        self.particle_materials, material_row = scene.particle_materials()
        self.nodes = NodeState(
            xy_m=scene.node_xy_m.copy(), displacement_m=np.zeros((n, 2)), velocity_m_s=np.zeros((n, 2)),
            stress_pa=np.zeros((n, 4)), plastic_strain=np.zeros(n), mass_kg=np.zeros(n), inertia_kg=np.zeros(n),
            material_row=material_row, fixed=scene.node_fixed.copy(),
            fixed_velocity_m_s=scene.node_fixed_velocity_m_s.copy(), slip=np.zeros((n, len(SLIP))),
        )
        self.walls = Walls(scene.wall_xy_m, scene.wall_friction)
        self.gravity_m_s2 = scene.gravity_m_s2.copy()
        self.mesh = None
        self.loads = ExternalLoads(
            active=False,
            node_force_n=np.zeros((n, 2)) if scene.node_load_n is None else scene.node_load_n,
            node_pore_pressure_pa=np.zeros(n) if scene.node_pore_pressure_pa is None else scene.node_pore_pressure_pa,
            phreatic_xy_m=np.zeros((0, 2)), phreatic_start=np.zeros(1, dtype=np.int64),
            node_phreatic_line=np.full(n, -1, dtype=np.int64),
            water_unit_weight_n_m3=float(scene.water_unit_weight_n_m3), pond_level_m=np.nan,
            pond_x_range_m=np.array(scene.pond_x_range_m, dtype=np.float64).reshape(2),
            boundary_edges=np.zeros((0, 2), dtype=np.int64), at_initial_positions=False, ramp_time_s=0.0,
        )
        self.loads = with_water(self.loads, scene, None, scene.phreatic_lines_m, scene.node_phreatic_line,
                                scene.pond_level_m)
        self.scratch = StepScratch.for_nodes(n)
        self.dissipated, self.loop = new_accumulators()
        self.counters = RunCounters()
        self.node_spacing_m = np.full(n, scene.spacing_m) if scene.node_spacing_m is None else scene.node_spacing_m
        self.remesher = Remesher(scene.spacing_m if scene.node_spacing_m is None else scene.node_spacing_m,
                                 scene.alpha, self.settings.min_angle_deg, self.settings.crowded_fraction)
        self.time_step = TimeStepPolicy(self.settings)
        self._relaxing = False  # True inside relax(): steps at the largest accepted cfl
        self._last_critical_dt = None  # (mesh, its inputs, the step) of the last critical step computed
        self._set_material_arrays(self.particle_materials)
        self.set_supports(Supports.of(n, scene.node_fixed, scene.node_fixed_velocity_m_s, scene.node_slip_length_m,
                                      scene.node_slip_side))

        self._set_mesh(self.remesher.triangulate(self.nodes.xy_m) if initial_mesh is None else initial_mesh)
        self._initial_mesh = self.mesh
        orphans = self.mesh.orphan_nodes
        if orphans.size and not allow_detached:
            raise DetachedParticlesError(
                f"{orphans.size} particles lie in no triangle of the initial mesh (first: {orphans[:5].tolist()}); "
                "check the spacing against the geometry or raise alpha"
            )
        cell_area = self.scratch.area_m2.copy()
        cell_area[orphans] = self.node_spacing_m[orphans] ** 2
        self.nodes.mass_kg[:] = scene.particle_density_kg_m3 * cell_area
        self.nodes.inertia_kg[:] = self.nodes.mass_kg
        self._choose_time_step()
        self.remesher.reset_angle_budget(self.nodes.xy_m, self.mesh, self.loop, after_rebuild=True)

    # ------------------------------------------------------------------ set-up
    def _set_material_arrays(self, materials: MaterialTable):
        self.materials = materials
        self.material_arrays = material_arrays(materials)
        self.speed_limit_m_s = float(materials.p_wave_speed_m_s[self.nodes.material_row].max())

    def _set_mesh(self, mesh: Mesh):
        """Use ``mesh`` from now on: cell areas and gradients on it (and its boundary, when ponded
        water loads it)."""
        self.mesh = mesh
        if self.loads.pond_level_m == self.loads.pond_level_m:  # not NaN: ponded water follows the boundary
            self.loads = self.loads._replace(boundary_edges=boundary_edges(mesh.elem_nodes))
        self.n_orphans = int(mesh.orphan_nodes.size)
        self.mesh_arrays = mesh.arrays
        smooth_velocity_gradient(self.nodes.xy_m, self.nodes.velocity_m_s, mesh.elem_nodes, mesh.elem_block_ptr,
                                 mesh.elem_colour_ptr, mesh.elem_colour_block, self.scratch.velocity_gradient,
                                 self.scratch.area_m2, kernel_threads(self.threads))

    def _critical_dt(self) -> float:
        """The critical step of the current mesh, positions, inertia and moduli; the last one again
        when none of them has changed (a stage set up from the original positions asks three times)."""
        mesh = self.mesh
        inputs = (self.nodes.xy_m, self.nodes.inertia_kg, self.nodes.material_row,
                  self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa)
        last = self._last_critical_dt
        if last is not None and last[0] is mesh and all(np.array_equal(a, b) for a, b in zip(last[1], inputs)):
            return last[2]
        value = float(critical_time_step(
            self.nodes.xy_m, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, self.nodes.inertia_kg,
            self.nodes.material_row, self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa,
        ))
        self._last_critical_dt = (mesh, tuple(a.copy() for a in inputs), value)
        return value

    def _choose_time_step(self):
        """dt of a dynamic stage on the current mesh (``timestep.TimeStepPolicy``)."""
        self.critical_dt_s = self._critical_dt()
        self.dt_s = self.time_step.dynamic(self.critical_dt_s)
        self._stage_first_dt_s = self.dt_s  # a stage sets it again when it starts

    def begin_stage(self, setup: StageSetup) -> None:
        """Set what a stage changes before it starts (``StageSetup``, in the order of its fields):
        its start, materials, supports, body force, water and load ramp."""
        if isinstance(setup.start, StressState):
            self.start_from(setup.start)
        elif setup.start == "original_positions":
            self.discard_displacement()
        elif setup.start != "continue":
            raise ValueError(f"StageSetup.start: must be 'continue', 'original_positions' or a StressState, "
                             f"got {setup.start!r}")
        self.set_materials(setup.materials)
        self.set_supports(setup.supports(self.n_particles))
        self.gravity_m_s2 = body_force_m_s2(setup.gravity_m_s2)
        self.loads = with_water(self.loads, self.scene, self.mesh, setup.phreatic_lines_m, setup.node_phreatic_line,
                                setup.pond_level_m)
        self.loads = with_load_ramp(self.loads, setup.load_ramp_s)

    def set_materials(self, materials: MaterialTable):
        """Use another material table from now on, with the rows of ``particle_materials`` (the
        elastic or reduced table of a stage, a step of a strength ramp).  The time step is chosen
        again for the new wave speeds."""
        if materials.n_rows != self.particle_materials.n_rows:
            raise ValueError(f"materials: expected {self.particle_materials.n_rows} rows, got {materials.n_rows}")
        self._set_material_arrays(materials)
        self._choose_time_step()
        self.supports.apply(self.nodes, materials)

    def set_supports(self, supports: Supports) -> None:
        """Use ``supports`` from now on (``stage_setup.Supports``), with the strength of the
        materials in use."""
        self.supports = supports
        supports.apply(self.nodes, self.materials)

    def discard_displacement(self):
        """Back to the initial positions and mesh, at rest, keeping the stresses (stage change)."""
        self.nodes.xy_m[:] = self.initial_xy_m
        self.nodes.displacement_m[:] = 0.0
        self.nodes.velocity_m_s[:] = 0.0
        self._set_mesh(self._initial_mesh)
        self._choose_time_step()
        self.remesher.reset_angle_budget(self.nodes.xy_m, self.mesh, self.loop, after_rebuild=True)

    def start_from(self, state: StressState):
        """Start from a stress state computed elsewhere (a stored gravity stage), at the initial
        positions and at rest."""
        if state.n_particles != self.n_particles:
            raise ValueError(f"StressState: expected {self.n_particles} particles, got {state.n_particles}")
        self.discard_displacement()
        self.nodes.stress_pa[:] = state.stress_pa
        self.nodes.plastic_strain[:] = state.plastic_strain

    # ------------------------------------------------------------------ mesh
    def rebuild_mesh(self):
        """Spread crowded particles and triangulate again (``remeshing``); the time step follows the
        new mesh.  A stage calls it when the mesh quality falls or a detached particle can rejoin.
        Raises ``_MeshCollapse`` (a DivergenceError for the stage) when the new mesh would cut the
        step below ``timestep.DT_COLLAPSE_FACTOR`` of the stage's first."""
        start = time.perf_counter()
        try:
            mesh, moved = self.remesher.rebuild(self.nodes, self.mesh)
            self.counters.smoothed += moved
            self._set_mesh(mesh)
            self.counters.rebuilds += 1
            self.remesher.reset_angle_budget(self.nodes.xy_m, self.mesh, self.loop, after_rebuild=True)
            if self._relaxing:
                self._set_inertia()  # the equalised inertia belongs to the mesh
            critical = self._critical_dt()
            self.critical_dt_s = critical
            new_dt = self.time_step.after_rebuild(critical, self.beta if self._relaxing else None)
            if new_dt < DT_COLLAPSE_FACTOR * self._stage_first_dt_s:
                raise _MeshCollapse(
                    f"the mesh degenerated: its critical time step fell to {critical:.3g} s "
                    f"(the stage started with dt = {self._stage_first_dt_s:.3g} s)"
                )
            self.dt_s = new_dt
        finally:
            self.counters.remesh_wall_s += time.perf_counter() - start

    # ------------------------------------------------------------------ stages
    def run(
        self,
        duration_s: float,
        damping: float = 0.0,
        record_interval_s: float | None = None,
        monitor_nodes=(),
        progress: Callable[[float], None] | None = None,
        stop: StopRule | None = None,
        snapshot: SnapshotHook | None = None,
        periodic: PeriodicAction | None = None,
    ) -> TimeSeries:
        """Dynamic stage: ``duration_s`` of explicit steps with local damping ``damping``; water
        pressures at the current positions.

        ``stop`` is asked between compiled calls whether the outcome is decided (see
        :data:`StopRule`); the stage then ends early and its notes say why.  ``snapshot``
        (:data:`SnapshotHook`: interval in s, callback) is called with the particles at the start,
        every interval and at the end (:meth:`snapshot`).  ``periodic`` (see
        :data:`PeriodicAction`) may change the simulation every interval.
        """
        self.loads = self.loads._replace(at_initial_positions=False)
        return self._stage(duration_s, damping, 0.0, record_interval_s, monitor_nodes, progress, stop, snapshot,
                           periodic)

    def relax(
        self,
        damping: float = 0.7,
        tolerance: float = 1e-4,
        max_duration_s: float = 10.0,
        record_interval_s: float | None = None,
        monitor_nodes=(),
        progress: Callable[[float], None] | None = None,
        snapshot: SnapshotHook | None = None,
        stop: StopRule | None = None,
        water_at_initial_positions: bool = False,
        elastic_solve_first: bool = False,
    ) -> TimeSeries:
        """Dynamic relaxation: locally damped steps until |f_unbalanced| / |m g| < ``tolerance``.

        The ratio is over the free directions of all particles (2-norms).  Stops at
        ``max_duration_s`` otherwise, with ``converged = False``, or when ``stop`` (as in
        :meth:`run`) gives a reason.

        Only the end state of a relaxation counts, not its path, so it steps at the largest
        accepted cfl, 1 / (1 + beta), whatever the solver's cfl or dt_s (the dynamic stages
        keep those).  On the reference slope: 2,758 steps instead of 4,938 at cfl 0.5, with
        the relaxed stresses equal within 3.4e-6 of their largest value (tolerance 1e-5).
        ``max_duration_s`` is pseudo-time at that step.

        ``water_at_initial_positions``: the water pressures act as at the initial positions
        (``external_forces``), for a gravity stage whose displacement the next stage discards;
        ``pore_pressure_pa`` reports them so until the next stage starts.

        ``elastic_solve_first``: when every material in use is elastic, start from the static
        small-strain response to the unbalanced force (:meth:`solve_elastic`); the damped steps
        then only correct the large-deformation geometry.  The series' note ``elastic_solve``
        says whether it applied.
        """
        if not tolerance > 0.0:
            raise ValueError(f"tolerance must be > 0, got {tolerance}")
        self._relaxing = True
        self.loads = self.loads._replace(at_initial_positions=bool(water_at_initial_positions))
        solve_note = self.solve_elastic(tolerance) if elastic_solve_first else "off"
        self._set_inertia()
        self.dt_s = self.time_step.relaxation(self.critical_dt_s, self.beta)
        try:
            series = self._stage(max_duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, stop,
                                 snapshot)
            series.notes["elastic_solve"] = solve_note
            return series
        finally:
            self._relaxing = False
            self._set_inertia()
            self._choose_time_step()

    def solve_elastic(self, tolerance: float) -> str:
        """Bring the particles to static equilibrium by direct solves (``elastic_solve``), where that
        is the state a relaxation approaches: every material elastic, supports that hold still, no
        walls, no particle sliding along a slip support (an elastic row holds them fixed), no load
        ramp, every particle in a triangle.  The unbalanced force at rest (weight, water and loads
        at the current stage time, the current stress) is balanced by the small-strain increment,
        the particles move by it and take its stress; the residual the moved geometry leaves is
        solved again with the same factorisation, until the unbalanced-force ratio is below
        ``SOLVE_MARGIN`` x ``tolerance`` (at most ``MAX_SOLVES`` times; each must divide it by
        1 / ``SOLVE_GAIN``, else the state is put back).  At rest afterwards.  Returns one line:
        what was done, or why not.  On the reference slope at h = 0.3 m the ratio fell
        1 -> 2.9e-4 -> 3.1e-7."""
        nodes = self.nodes
        reason = None
        if self.materials.plastic:
            reason = "a material is not elastic"
        elif self.walls.xy_m.shape[0]:
            reason = "walls"
        elif np.any(nodes.slip[:, SLIP_SIDE] != 0.0):  # (an elastic row on a slip support is held fixed)
            reason = "slip supports"
        elif self.prescribes_motion:
            reason = "prescribed motion"
        elif self.loads.ramp_time_s > 0.0:
            reason = "a load ramp"
        elif self.n_orphans:
            reason = "particles outside the mesh"
        elif np.count_nonzero(~nodes.fixed) > DIRECT_SOLVE_MAX_DOFS:
            reason = f"more than {DIRECT_SOLVE_MAX_DOFS} free directions"
        if reason is not None:
            return f"not applicable ({reason})"
        start = time.perf_counter()
        row = nodes.material_row
        free = ~nodes.fixed
        weight_sq = float(np.sum((nodes.mass_kg[:, None] * self.gravity_m_s2[None, :])[free] ** 2))
        unbalanced = np.zeros((self.n_particles, 2))
        before = (nodes.xy_m.copy(), nodes.displacement_m.copy(), nodes.stress_pa.copy())
        try:
            system = ElasticSystem(nodes.xy_m, self.mesh.elem_nodes, self.material_arrays.lame_lambda_pa[row],
                                   self.material_arrays.shear_modulus_pa[row], free)
            ratios = []
            for _ in range(MAX_SOLVES + 1):
                unbalanced_force_at_rest(nodes, self.scratch, self.mesh_arrays, self.material_arrays, self.loads,
                                         self.gravity_m_s2, 0.0, unbalanced)
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
        self.critical_dt_s = self._critical_dt()
        trail = " -> ".join(f"{r:.2g}" for r in ratios)
        return (f"{len(ratios) - 1} direct solves in {time.perf_counter() - start:.2f} s, unbalanced-force ratio "
                f"{trail}")

    def _set_inertia(self) -> None:
        """The inertia the forces accelerate from now on, and the critical step on it.  Outside a
        relaxation, the masses m_k.  Only the end state of a relaxation counts, so its inertia is
        free (the weight stays m_k g), and it is density-scaled:

        - ``settings.density_scaling`` on a graded cloud: to the coarsest spacing,
          m_i,k = m_k (h_max / h_k)^2, which gives every particle about the critical step of the
          coarsest ones (in 2D a cell's stiffness does not depend on its size, its mass goes as
          h^2).  The fine particles then respond that much more slowly in pseudo-time: a
          relaxation whose slow part lies in the fine zone (a mechanism, where the cloud is
          refined) needs as many steps as without scaling and a longer ``max_duration_s``;
        - ``settings.uniform_relaxation_step``: then no cell's step below the median cell's
          (``timestep.equalised_inertia``, recomputed on every mesh): the few cells that hold the
          step down, at the free surface, take more inertia, and the relaxation about half the
          steps (docs/method.md, section 5)."""
        nodes = self.nodes
        nodes.inertia_kg[:] = nodes.mass_kg
        if self._relaxing and self.settings.density_scaling and self.scene.node_spacing_m is not None:
            nodes.inertia_kg[:] *= (self.node_spacing_m.max() / self.node_spacing_m) ** 2
        if self._relaxing and self.settings.uniform_relaxation_step:
            mesh = self.mesh
            omega_sq = cell_frequency_bounds(
                nodes.xy_m, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, nodes.inertia_kg,
                nodes.material_row, self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa,
            )
            nodes.inertia_kg[:] = equalised_inertia(nodes.inertia_kg, omega_sq, mesh.node_node_ptr,
                                                    mesh.node_node_idx)
        self.critical_dt_s = self._critical_dt()

    @property
    def prescribes_motion(self) -> bool:
        """Whether a support moves (a nonzero prescribed velocity): it does work the energy budget
        does not count, and a relaxation's state is not a static solution."""
        nodes = self.nodes
        return bool(np.any(nodes.fixed_velocity_m_s[nodes.fixed] != 0.0))

    @property
    def beta(self) -> float:
        """The stabilisation of the steps now: ``stabilisation_beta``, except in a relaxation whose
        materials are all elastic, which runs without the bonds.  They are a viscosity (zero at
        rest), so the elastic equilibrium the relaxation converges to does not depend on them,
        and a step costs about a quarter less without them, at a 1 + beta longer step.  A
        relaxation with plasticity keeps them: its end state depends on its path, and without
        the bonds the quasi-static SRF runs of the undrained slope of Griffiths & Lane found
        an FOS of 1.346 instead of 1.446 (docs/method.md, section 8)."""
        if self._relaxing and not self.materials.plastic:
            return 0.0
        return float(self.settings.stabilisation_beta)

    def _parameters(self, damping: float, tolerance: float) -> StepParameters:
        return StepParameters(
            self.gravity_m_s2, self.dt_s, float(damping), self.beta,
            self.scene.spacing_m, self.speed_limit_m_s, float(tolerance), self.remesher.threshold_rad,
            ANGLE_MARGIN_RAD, kernel_threads(self.threads),
        )

    def _stage(self, duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, stop=None,
               snapshot=None, periodic=None):
        if not duration_s > 0.0:
            raise ValueError(f"duration_s must be > 0, got {duration_s}")
        if not 0.0 <= damping < 1.0:
            raise ValueError(f"damping must be in [0, 1), got {damping}")
        start_wall = time.perf_counter()
        self.threads = set_threads(self.settings.threads, self.n_particles)  # numba's choice is per calling thread
        monitor_nodes = np.ascontiguousarray(monitor_nodes, dtype=np.int64).reshape(-1)
        interval = float(record_interval_s) if record_interval_s else max(duration_s / 1000.0, self.dt_s)
        records = RecordBuffers.empty(int(min(duration_s / interval, 1e6)) + 2, monitor_nodes.size)
        self.loop[LOOP_NEXT_RECORD] = interval
        self.dissipated[:] = 0.0  # dissipation is recorded since the stage start
        self._record(records, 0.0, monitor_nodes)

        self._stage_first_dt_s = self.dt_s
        start = _StageStart(self.counters.rebuilds, self.counters.smoothed, self.counters.remesh_wall_s,
                            float(self.loop[LOOP_MESH_CHECKS]))
        # prescribed motion does work the budget does not count
        energy_watch = None if self.prescribes_motion else EnergyWatch(records)
        stage_time = 0.0
        n_steps = 0
        converged = None if tolerance == 0.0 else False
        stop_reason = ""
        schedule = StageSchedule(duration_s, self.n_particles, stop is not None,
                                 None if snapshot is None else float(snapshot[0]),
                                 None if periodic is None else float(periodic[0]))
        if snapshot is not None:
            snapshot[1](self.snapshot(0.0))

        def partial_series():
            return self._series(records, n_steps, start, start_wall, converged)

        while schedule.running(stage_time, self.dt_s):
            schedule.plan_landing_check(self.n_orphans > 0, n_steps, float(np.abs(self.nodes.velocity_m_s).max()),
                                        self.scene.spacing_m, self.dt_s)
            n_want = schedule.next_call_steps(stage_time, self.dt_s, n_steps)
            call_start = time.perf_counter()
            status, done = advance(
                self.nodes, self.scratch, self.mesh_arrays, self.material_arrays,
                self.walls, self.loads, self._parameters(damping, tolerance), n_want, stage_time, interval, monitor_nodes,
                records, self.dissipated, self.loop,
            )
            schedule.adapt(done, time.perf_counter() - call_start)
            stage_time += done * self.dt_s
            n_steps += done
            self.counters.steps += done

            reason = None
            if status in (STATUS_NOT_FINITE, STATUS_RUNAWAY):
                reason = speed_reason(status == STATUS_NOT_FINITE, self.loop[LOOP_LAST_MAX_SPEED],
                                      self.speed_limit_m_s)
            elif energy_watch is not None:
                reason = energy_watch.reason(records)
            if reason is not None:
                raise DivergenceError(reason, self.counters.steps, stage_time, partial_series())
            try:
                if status in (STATUS_INVERTED, STATUS_MESH_CHECK):
                    self.rebuild_mesh()
                elif schedule.landing_check_due(n_steps):
                    if self.n_orphans and self.remesher.orphans_can_rejoin(self.nodes.xy_m, self.mesh):
                        self.rebuild_mesh()
            except _MeshCollapse as collapse:
                raise DivergenceError(str(collapse), self.counters.steps, stage_time, partial_series()) from None
            if status == STATUS_BUFFER_FULL:
                records = records.grown()
            elif status == STATUS_CONVERGED:
                converged = True
                break
            elif status not in (STATUS_DONE, STATUS_MESH_CHECK, STATUS_INVERTED):
                raise RuntimeError(f"unknown status {status} from the time loop")
            if schedule.stop_check_due(stage_time, self.dt_s):
                n_rec = records.n_filled
                early = stop(records.time_s[:n_rec], records.max_displacement_m[:n_rec],
                             records.energy_j_per_m[:n_rec])
                if early:
                    stop_reason = str(early)
                    break
            if schedule.snapshot_due(stage_time, self.dt_s):
                snapshot[1](self.snapshot(stage_time))
            if schedule.action_due(stage_time, self.dt_s):
                periodic[1](stage_time)
            if progress is not None:
                progress(min(stage_time / duration_s, 1.0))
        if schedule.final_snapshot_due(stage_time, self.dt_s):
            snapshot[1](self.snapshot(stage_time))  # the end, unless it was a snapshot time already
        if records.time_s[records.n_filled - 1] < stage_time - 1e-12 * max(stage_time, 1.0):
            if records.n_filled >= records.capacity:
                records = records.grown()
            self._record(records, stage_time, monitor_nodes)
        if progress is not None:
            progress(1.0)
        series = self._series(records, n_steps, start, start_wall, converged)
        if stop_reason:
            series.notes["early_stop"] = f"stopped at t = {series.time_s[-1]:.4g} s of {duration_s:g} s: {stop_reason}"
        return series

    def _record(self, records: RecordBuffers, time_s: float, monitor_nodes: np.ndarray):
        slot = records.n_filled
        record_state(slot, time_s, self.nodes, self.scratch.area_m2, self.material_arrays, self.gravity_m_s2,
                     monitor_nodes, self.dissipated, records)
        records.count[0] = slot + 1

    def _series(self, records: RecordBuffers, n_steps: int, start: "_StageStart", start_wall: float,
                converged) -> TimeSeries:
        beta = self.beta
        n_remesh = self.counters.rebuilds - start.rebuilds
        n_checks = int(self.loop[LOOP_MESH_CHECKS] - start.mesh_checks)
        n_walls = self.walls.xy_m.shape[0]
        plastic = self.materials.plastic
        notes = {
            "stabilisation": (
                f"on (beta = {beta:g})" if beta > 0
                else "off in a relaxation of elastic materials (the bonds vanish at rest): bond loop skipped"
                if self._relaxing and self.settings.stabilisation_beta > 0 else "off (beta = 0): bond loop skipped"
            ),
            "contact": (
                f"on ({n_walls} walls, {int(self.loop[LOOP_CONTACTS])} particles touching at the end)"
                if n_walls
                else "off (no walls): contact loop skipped"
            ),
            "remesh": (
                f"{n_remesh} rebuilds and {n_checks} exact quality checks in {n_steps} steps; "
                f"{self.counters.smoothed - start.smoothed} crowded particles smoothed; "
                f"{self.counters.remesh_wall_s - start.remesh_wall_s:.2f} s rebuilding"
            ),
            "plasticity": "on" if plastic else "off (all materials elastic)",
            "water_and_loads": "on" if self.loads.active else "off (no water, no surface loads): skipped",
            "particles_outside_mesh": f"{self.n_orphans} at the end",
        }
        series = TimeSeries.from_records(
            records, dt_s=self.dt_s, n_steps=n_steps, n_remesh=n_remesh, n_mesh_checks=n_checks,
            wall_time_s=time.perf_counter() - start_wall, converged=converged,
            unbalanced_force_ratio=float(self.loop[LOOP_LAST_RATIO]), notes=notes,
        )
        if converged is True:
            notes["early_stop"] = f"relaxation converged after {n_steps} steps (t = {series.time_s[-1]:.4g} s)"
        return series

    # ------------------------------------------------------------------ views
    @property
    def n_particles(self) -> int:
        return self.scene.n_particles

    @property
    def initial_xy_m(self) -> np.ndarray:
        """Positions at the start (the scene's particles), (n, 2) m."""
        return self.scene.node_xy_m

    @property
    def node_area_m2(self) -> np.ndarray:
        """Smoothing-cell areas A_k on the current mesh (as of the last step), a copy."""
        return self.scratch.area_m2.copy()

    @property
    def pore_pressure_pa(self) -> np.ndarray:
        """Pore pressure u of every particle at its current position (n,), Pa, compression positive
        (``stage_setup.pore_pressure_pa``; at the initial positions, x - u, within a relaxation that
        asks for it); zeros without water."""
        return pore_pressure_pa(self.loads, self.nodes)

    def snapshot(self, time_s: float = math.nan) -> Snapshot:
        """The particles as they are now (copies), at stage time ``time_s``."""
        nodes = self.nodes
        return Snapshot(
            time_s=float(time_s), xy_m=nodes.xy_m.copy(), initial_xy_m=self.initial_xy_m.copy(),
            displacement_m=nodes.displacement_m.copy(), velocity_m_s=nodes.velocity_m_s.copy(),
            stress_pa=nodes.stress_pa.copy(), plastic_strain=nodes.plastic_strain.copy(),
            area_m2=self.node_area_m2, mass_kg=nodes.mass_kg.copy(), density_kg_m3=self.scene.particle_density_kg_m3,
            pore_pressure_pa=self.pore_pressure_pa, material=self.scene.node_material.copy(),
            material_names=tuple(self.scene.materials.name), elem_nodes=self.mesh.elem_nodes.copy(),
            spacing_m=float(self.scene.spacing_m), dt_s=float(self.dt_s), critical_dt_s=float(self.critical_dt_s),
            particle_spacing_m=None if self.scene.node_spacing_m is None else self.scene.node_spacing_m.copy(),
        )


class _StageStart(NamedTuple):
    """Counters at the start of a stage, to report the stage's own share."""

    rebuilds: int
    smoothed: int
    remesh_wall_s: float
    mesh_checks: float


class _MeshCollapse(Exception):
    """Raised by a rebuild that would stall the run; turned into DivergenceError by the stage."""
