"""What a stage sets before it starts: its supports, body force, water and load ramp.

A stage hands the simulation one :class:`StageSetup`; ``Simulation.begin_stage`` applies it in
the order of its fields (where it starts from, the materials, then the pieces of this module).
Each piece is a value or a function of values: the supports (:class:`Supports`, applied again
whenever the materials change, since a slip support's strength is its soil's), the body force
(:func:`body_force_m_s2`), the water (:func:`with_water`, and the pore pressure it gives,
:func:`pore_pressure_pa`) and the load ramp (:func:`with_load_ramp`) of ``state.ExternalLoads``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spfem_core.materials.table import MaterialTable
from spfem_core.mesh import Mesh, boundary_edges
from spfem_core.scene import Scene
from spfem_core.snapshot import StressState
from spfem_core.state import SLIP_COHESION, SLIP_FRICTION, SLIP_SIDE, ExternalLoads, NodeState


@dataclass(frozen=True, eq=False)
class StageSetup:
    """What a stage sets before it starts; ``Simulation.begin_stage`` applies it in the order of
    the fields: where it starts from, then the materials (which fix the time step), supports,
    body force, water and load ramp.

    ``start``: "continue" (the state the last stage left), "original_positions" (at rest at the
    initial positions and mesh, stresses kept, displacements discarded) or a ``StressState`` (that
    stress and plastic strain, at rest at the initial positions).
    """

    materials: MaterialTable  # same rows as Simulation.particle_materials (elastic, reduced, ...)
    node_fixed: np.ndarray  # (n, 2) bool: velocity prescribed
    node_fixed_velocity_m_s: np.ndarray  # (n, 2) the prescribed velocity
    gravity_m_s2: np.ndarray  # (2,) body acceleration, gravity with any pseudo-static seismic part
    node_slip_length_m: np.ndarray | None = None  # (n,) share L_k of a slip support (0 or None: none)
    node_slip_side: np.ndarray | None = None  # (n,) side s = +-1 the support lies on along the prescribed direction
    phreatic_lines_m: tuple = ()  # piezometric lines, each (n_points, 2) with x increasing
    node_phreatic_line: np.ndarray | None = None  # (n,) line of each particle, -1: none (default: the first, or none)
    pond_level_m: float | None = None  # ponded water level; None: none
    load_ramp_s: float = 0.0  # the surface loads grow from zero over this stage time (0: at once)
    start: str | StressState = "continue"

    def supports(self, n_particles: int) -> Supports:
        """The stage's supports, checked."""
        return Supports.of(n_particles, self.node_fixed, self.node_fixed_velocity_m_s, self.node_slip_length_m,
                           self.node_slip_side)


@dataclass(frozen=True, eq=False)
class Supports:
    """The prescribed velocities of a stage and its slip supports (e.g. a retaining side released
    for a collapse, a base the soil slides along)."""

    fixed: np.ndarray  # (n, 2) bool: velocity prescribed in that direction
    fixed_velocity_m_s: np.ndarray  # (n, 2) the prescribed velocity
    slip_length_m: np.ndarray  # (n,) share L_k of a slip support
    slip_side: np.ndarray  # (n,) side s = +-1 the support lies on along the prescribed direction; 0: none

    @classmethod
    def of(cls, n_particles: int, node_fixed, node_fixed_velocity_m_s, node_slip_length_m=None,
           node_slip_side=None) -> Supports:
        """The supports of ``n_particles`` (``StageSetup``'s fields; None: no slip support).  A slip
        support needs exactly one prescribed direction and a share L_k > 0."""
        n = n_particles
        fixed = np.asarray(node_fixed, dtype=bool).reshape(n, 2).copy()
        velocity = np.asarray(node_fixed_velocity_m_s, dtype=np.float64).reshape(n, 2).copy()
        length = np.zeros(n) if node_slip_length_m is None else np.asarray(node_slip_length_m, float).reshape(n)
        side = np.zeros(n) if node_slip_side is None else np.asarray(node_slip_side, float).reshape(n)
        slipping = side != 0.0
        if np.any(slipping & ((fixed.sum(axis=1) != 1) | ~(length > 0.0))):
            raise ValueError("node_slip_side: a slip support needs exactly one prescribed direction and a share "
                             "L_k > 0 of the support")
        return cls(fixed, velocity, length, side)

    def apply(self, nodes: NodeState, materials: MaterialTable) -> None:
        """``nodes.fixed``, ``fixed_velocity_m_s`` and ``slip`` from these supports and the strength
        of ``materials`` (the table in use): C = c L_k + tan(phi) N of the particle's row
        (``MaterialTable.slip_strength``, ``integration``); a particle that cannot slide (an
        elastic row, c = inf) is held fixed, its free direction too, at rest."""
        nodes.fixed[:] = self.fixed
        nodes.fixed_velocity_m_s[:] = self.fixed_velocity_m_s
        slip = nodes.slip
        slip[:] = 0.0
        side = self.slip_side
        if not np.any(side):
            return
        cohesion, tan_friction = materials.slip_strength()
        row = nodes.material_row
        sliding = (side != 0.0) & np.isfinite(cohesion[row])
        slip[sliding, SLIP_COHESION] = cohesion[row[sliding]] * self.slip_length_m[sliding]
        slip[sliding, SLIP_FRICTION] = tan_friction[row[sliding]]
        slip[sliding, SLIP_SIDE] = side[sliding]
        held = np.flatnonzero((side != 0.0) & ~sliding)
        nodes.fixed_velocity_m_s[held] = np.where(nodes.fixed[held], nodes.fixed_velocity_m_s[held], 0.0)
        nodes.fixed[held] = True


def body_force_m_s2(gravity_m_s2) -> np.ndarray:
    """The body acceleration (2,) m/s^2 of a stage, e.g. gravity with a pseudo-static seismic part."""
    gravity = np.asarray(gravity_m_s2, dtype=np.float64).reshape(2)
    if not np.all(np.isfinite(gravity)):
        raise ValueError(f"gravity_m_s2: must be finite, got {gravity.tolist()}")
    return np.ascontiguousarray(gravity)


def with_water(loads: ExternalLoads, scene: Scene, mesh: Mesh | None, phreatic_lines_m=(), node_phreatic_line=None,
               pond_level_m: float | None = None) -> ExternalLoads:
    """``loads`` with pore and ponded water from now on (a water-level change): the piezometric
    lines, the line of each particle (-1: none; default: the first line for all, or none), the
    ponded water level (None: none) along the boundary of ``mesh`` (None: not meshed yet).  The
    loads are active (their kernel runs) when there are surface loads, an ru pore pressure, a line
    or a pond."""
    n = scene.n_particles
    lines = tuple(np.ascontiguousarray(line, dtype=np.float64).reshape(-1, 2) for line in phreatic_lines_m)
    if node_phreatic_line is None:
        node_phreatic_line = np.full(n, 0 if lines else -1, dtype=np.int64)
    node_line = np.ascontiguousarray(node_phreatic_line, dtype=np.int64).reshape(n)
    pond = np.nan if pond_level_m is None else float(pond_level_m)
    return loads._replace(
        active=bool(scene.node_load_n is not None or scene.node_pore_pressure_pa is not None
                    or np.any(node_line >= 0) or pond == pond),
        phreatic_xy_m=np.ascontiguousarray(np.vstack([np.zeros((0, 2)), *lines])),
        phreatic_start=np.cumsum([0] + [line.shape[0] for line in lines], dtype=np.int64),
        node_phreatic_line=node_line, pond_level_m=pond,
        boundary_edges=(boundary_edges(mesh.elem_nodes) if pond == pond and mesh is not None
                        else np.zeros((0, 2), dtype=np.int64)),
    )


def pore_pressure_pa(loads: ExternalLoads, nodes: NodeState) -> np.ndarray:
    """Pore pressure u of every particle (n,), Pa, compression positive: the one it carries (ru)
    plus gamma_w times its depth below its piezometric line, at its current position (at its
    initial one, x - u, where the loads say so), as ``external_forces`` computes it."""
    u = loads.node_pore_pressure_pa.copy()
    xy = nodes.xy_m - nodes.displacement_m if loads.at_initial_positions else nodes.xy_m
    for i in range(loads.phreatic_start.size - 1):
        line = loads.phreatic_xy_m[loads.phreatic_start[i]:loads.phreatic_start[i + 1]]
        on = loads.node_phreatic_line == i
        head = np.interp(xy[on, 0], line[:, 0], line[:, 1]) - xy[on, 1]
        u[on] += loads.water_unit_weight_n_m3 * np.maximum(head, 0.0)
    return u


def with_load_ramp(loads: ExternalLoads, ramp_time_s: float) -> ExternalLoads:
    """``loads`` whose surface loads grow linearly from zero over ``ramp_time_s`` of stage time
    (0: applied at once); a relaxation does not converge before the ramp ends."""
    if not ramp_time_s >= 0.0:
        raise ValueError(f"ramp_time_s: must be >= 0, got {ramp_time_s}")
    return loads._replace(ramp_time_s=float(ramp_time_s))
