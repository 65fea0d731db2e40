"""A simulation: the particle state of a scene and the stages run on it.

:class:`Simulation` owns the state (the particles, their mesh, the materials, supports, body force
and loads in use, the time step) and ties together the rooms that act on it: a stage is set up
from a ``stage_setup.StageSetup`` (:meth:`Simulation.begin_stage`), runs in the loop between
compiled calls of ``stage_loop`` (:meth:`Simulation.run`, :meth:`Simulation.relax`), and a
relaxation may start from the direct solve of ``elastic_solve`` (:meth:`Simulation.solve_elastic`).
What follows from the state it keeps itself: the mesh, rebuilt by ``remeshing``; the critical and
chosen time steps (``timestep.TimeStepPolicy``); the inertia of a relaxation.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from spfem_core import elastic_solve, stage_loop
from spfem_core.divergence import MeshCollapse
from spfem_core.jit import kernel_threads, set_threads
from spfem_core.materials.table import MaterialTable
from spfem_core.mesh import Mesh, boundary_edges
from spfem_core.records import TimeSeries
from spfem_core.remeshing import Remesher
from spfem_core.scene import Scene
from spfem_core.settings import SolverSettings
from spfem_core.smoothing import smooth_velocity_gradient
from spfem_core.snapshot import Snapshot, StressState
from spfem_core.stage_loop import PeriodicAction, SnapshotHook, StopRule
from spfem_core.stage_setup import StageSetup, Supports, body_force_m_s2, pore_pressure_pa, with_load_ramp, with_water
from spfem_core.state import SLIP, STRESS_WIDTH, ExternalLoads, MaterialArrays, NodeState, StepScratch, Walls
from spfem_core.stepper import new_accumulators
from spfem_core.timestep import (
    DT_COLLAPSE_FACTOR,
    TimeStepPolicy,
    cell_frequency_bounds,
    critical_time_step,
    equalised_inertia,
)


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
            stress_pa=np.zeros((n, STRESS_WIDTH)), plastic_strain=np.zeros(n), mass_kg=np.zeros(n),
            inertia_kg=np.zeros(n), material_row=material_row, fixed=scene.node_fixed.copy(),
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
        self.relaxing = False  # True inside relax(): steps at the largest accepted cfl
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
        self.choose_time_step()
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

    def update_critical_dt(self) -> float:
        """``critical_dt_s``: the critical step of the current mesh, positions, inertia and moduli,
        computed again only when one of them has changed (a stage set up from the original
        positions asks three times); returns it."""
        mesh = self.mesh
        inputs = (self.nodes.xy_m, self.nodes.inertia_kg, self.nodes.material_row,
                  self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa)
        last = self._last_critical_dt
        if last is None or last[0] is not mesh or not all(np.array_equal(a, b) for a, b in zip(last[1], inputs)):
            value = float(critical_time_step(
                self.nodes.xy_m, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, self.nodes.inertia_kg,
                self.nodes.material_row, self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa,
            ))
            self._last_critical_dt = (mesh, tuple(a.copy() for a in inputs), value)
        self.critical_dt_s = self._last_critical_dt[2]
        return self.critical_dt_s

    def choose_time_step(self):
        """dt of a dynamic stage on the current mesh (``timestep.TimeStepPolicy``)."""
        self.dt_s = self.time_step.dynamic(self.update_critical_dt())
        self.stage_first_dt_s = self.dt_s  # a stage sets it again when it starts

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
        self.choose_time_step()
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
        self.choose_time_step()
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
        Raises ``MeshCollapse`` (a DivergenceError for the stage) when the new mesh would cut the
        step below ``timestep.DT_COLLAPSE_FACTOR`` of the stage's first."""
        start = time.perf_counter()
        try:
            mesh, moved = self.remesher.rebuild(self.nodes, self.mesh)
            self.counters.smoothed += moved
            self._set_mesh(mesh)
            self.counters.rebuilds += 1
            self.remesher.reset_angle_budget(self.nodes.xy_m, self.mesh, self.loop, after_rebuild=True)
            if self.relaxing:
                self.set_inertia()  # the equalised inertia belongs to the mesh
            critical = self.update_critical_dt()
            new_dt = self.time_step.after_rebuild(critical, self.beta if self.relaxing else None)
            if new_dt < DT_COLLAPSE_FACTOR * self.stage_first_dt_s:
                raise MeshCollapse(
                    f"the mesh degenerated: its critical time step fell to {critical:.3g} s "
                    f"(the stage started with dt = {self.stage_first_dt_s:.3g} s)"
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
        return stage_loop.run(self, duration_s, damping, record_interval_s, monitor_nodes, progress, stop, snapshot,
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
        :meth:`run`) gives a reason.  Only the end state of a relaxation counts, so it steps at
        the largest accepted cfl whatever the solver's cfl or dt_s (``stage_loop.relax``):
        ``max_duration_s`` is pseudo-time at that step.

        ``water_at_initial_positions``: the water pressures act as at the initial positions
        (``external_forces``), for a gravity stage whose displacement the next stage discards;
        ``pore_pressure_pa`` reports them so until the next stage starts.

        ``elastic_solve_first``: when every material in use is elastic, start from the static
        small-strain response to the unbalanced force (:meth:`solve_elastic`); the damped steps
        then only correct the large-deformation geometry.  The series' note ``elastic_solve``
        says whether it applied.
        """
        return stage_loop.relax(self, damping, tolerance, max_duration_s, record_interval_s, monitor_nodes, progress,
                                snapshot, stop, water_at_initial_positions, elastic_solve_first)

    def solve_elastic(self, tolerance: float) -> str:
        """Bring the particles to static equilibrium by direct solves, where that is the state a
        relaxation approaches (``elastic_solve.solve_elastic``); at rest afterwards.  Returns one
        line: what was done, or why not."""
        return elastic_solve.solve_elastic(self, tolerance)

    def set_inertia(self) -> None:
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
        if self.relaxing and self.settings.density_scaling and self.scene.node_spacing_m is not None:
            nodes.inertia_kg[:] *= (self.node_spacing_m.max() / self.node_spacing_m) ** 2
        if self.relaxing and self.settings.uniform_relaxation_step:
            mesh = self.mesh
            omega_sq = cell_frequency_bounds(
                nodes.xy_m, mesh.elem_nodes, mesh.node_node_ptr, mesh.node_node_idx, nodes.inertia_kg,
                nodes.material_row, self.material_arrays.lame_lambda_pa, self.material_arrays.shear_modulus_pa,
            )
            nodes.inertia_kg[:] = equalised_inertia(nodes.inertia_kg, omega_sq, mesh.node_node_ptr,
                                                    mesh.node_node_idx)
        self.update_critical_dt()

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
        if self.relaxing and not self.materials.plastic:
            return 0.0
        return float(self.settings.stabilisation_beta)

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
