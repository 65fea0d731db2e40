"""A study's transient flow (``[transient]``): its problem on the particles' first mesh, solved, and
the water at one time that a case's particles carry.

1. The mesh and conductivities are the steady flow's (``workflows.seepage.flow``): the simulation's
   first mesh of the study's cloud, a triangle taking the material whose region holds its centroid;
   each material its soil-water curve (``spfem_core.soil_water``).
2. The conditions (``workflows.transient.table``), each entry on the mesh's boundary particles inside
   its box, a later one over an earlier one: rain (``FluxBoundary``: the edges both of whose ends it
   selects, half each, per horizontal length or per length of the edge; mm/h to m/s), a reservoir
   (``ReservoirBoundary``, with the ground its water stands on within its box's abscissae, so that the
   water's load as it falls unloads the pore pressure below by its ``loading_efficiency``), a seepage
   face, a total or pressure head (``HeadBoundary``).
3. The initial heads: hydrostatic below the initial water table (with the suction limit), or the
   steady flow of ``[seepage]``; then ``spfem_core.transient_seepage.solve_transient_flow`` to
   ``end_time_h``, saving the times of the FOS, ``water_at_h`` and ``saved_times`` evenly spaced.

:func:`water_at` gives what the particles carry at a time (:class:`WaterAt`): with suction,
u = S_e(psi) gamma_w psi (negative above the water table: the suction stress of Lu & Likos, Bishop's
chi = S_e), else gamma_w max(psi, 0); the saturated density where psi >= 0; and a reservoir's water on
the surface below its level at that time.  As with steady seepage the pressure stays with the
particles through the stages (docs/method.md, sections 15 and 17).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import surface_height_m
from spfem_core.mesh import boundary_edges, triangulate
from spfem_core.seepage import conductivity_tensor
from spfem_core.soil_water import Gardner, VanGenuchten
from spfem_core.transient_seepage import (
    FlowNotConverged,
    FluxBoundary,
    HeadBoundary,
    History,
    ReservoirBoundary,
    SeepageFace,
    TransientProblem,
    TransientSettings,
    TransientSolution,
    boundary_flux_weights_m,
    hydrostatic_head_m,
    solve_transient_flow,
)
from workflows.box import TOLERANCE_PER_SPACING
from workflows.fields import StudyError
from workflows.particles import cloud_of_geometry, rows_of_materials
from workflows.transient.table import HOUR_S, MM_H_TO_M_S
from workflows.water.pressure import densities

DEFAULT_WATER_UNIT_WEIGHT_N_M3 = 9810.0
POND_SLACK = 0.5
"""A reservoir's water on the surface reaches this fraction of the spacing beyond its box (as
``water.pressure.POND_SLACK``)."""


@dataclass
class TransientFlow:
    """A study's transient flow on its particles (module doc) and its solution."""

    node_xy_m: np.ndarray
    elem_nodes: np.ndarray
    elem_material: np.ndarray
    problem: TransientProblem
    solution: TransientSolution
    reservoirs: tuple  # (its level History, (x_min, x_max) of its box) of each reservoir entry
    water_unit_weight_n_m3: float
    suction_in_strength: bool
    wall_time_s: float

    def index_at(self, time_h: float) -> int:
        """The saved time equal to ``time_h`` (it is one of those the study saves)."""
        k = int(np.argmin(np.abs(self.solution.times_s - time_h * HOUR_S)))
        if abs(self.solution.times_s[k] - time_h * HOUR_S) > 1e-6 * max(1.0, time_h * HOUR_S):
            raise ValueError(f"transient: {time_h:g} h is not a saved time (a bug)")
        return k

    def water_at(self, time_h: float) -> WaterAt:
        """What the particles carry at ``time_h`` (module doc)."""
        k = self.index_at(time_h)
        psi = self.solution.head_m[k] - self.node_xy_m[:, 1]
        levels = [(history.at(time_h * HOUR_S), span) for history, span in self.reservoirs]
        return WaterAt(time_h, self.node_xy_m, self.elem_nodes, psi, self.solution.effective_saturation[k],
                       self.water_unit_weight_n_m3, self.suction_in_strength, tuple(levels),
                       float(self.solution.balance_fraction()[:k + 1].max()), self.wall_time_s)


@dataclass
class WaterAt:
    """The water at one time, as the particles carry it (module doc)."""

    time_h: float
    node_xy_m: np.ndarray
    elem_nodes: np.ndarray
    pressure_head_m: np.ndarray  # (n,) psi
    effective_saturation: np.ndarray  # (n,) S_e
    water_unit_weight_n_m3: float
    suction_in_strength: bool
    reservoir_levels: tuple  # (level_m, (x_min, x_max)) of each reservoir at this time
    balance_fraction: float = 0.0  # the flow's mass balance to this time: the worst closure of its saved times
    flow_wall_time_s: float = 0.0  # to build and solve the flow

    def pore_pressure_pa(self) -> np.ndarray:
        """u = S_e gamma_w psi with suction (negative above the water table), else gamma_w max(psi, 0)."""
        psi = self.pressure_head_m
        if self.suction_in_strength:
            return self.water_unit_weight_n_m3 * np.where(psi >= 0.0, psi, self.effective_saturation * psi)
        return self.water_unit_weight_n_m3 * np.maximum(psi, 0.0)

    def saturated(self) -> np.ndarray:
        """Particles at or below the water table (psi >= 0)."""
        return self.pressure_head_m >= 0.0

    def line(self) -> str:
        """The report's line on it."""
        psi = self.pressure_head_m
        wet = f"{np.mean(psi >= 0.0):.0%} of the particles saturated"
        return (f"transient water at {self.time_h:g} h: {wet}, pressure head {psi.min():.3g} to {psi.max():.3g} m"
                + ("" if self.suction_in_strength else " (suction left out of the strength)")
                + f"; the flow's mass balance closed to {self.balance_fraction:.1e} ({self.flow_wall_time_s:.1f} s)")


def curve_of(entry):
    """The core's curve of a ``[[transient.curves]]`` entry."""
    if entry.model == "gardner":
        return Gardner(entry.residual_water_content, entry.saturated_water_content, entry.alpha_1_m,
                       entry.specific_storage_1_m)
    return VanGenuchten(entry.residual_water_content, entry.saturated_water_content, entry.alpha_1_m, entry.n,
                        entry.specific_storage_1_m)


def rain_history(entry) -> History:
    """A rain entry's flux into the surface (m/s) against time (s): its intensity, constant or piecewise
    constant between the points of its history (each holds until the next time; none before the first),
    less its evaporation (negative where that is the larger)."""
    evaporation_m_s = (entry.evaporation_mm_h or 0.0) * MM_H_TO_M_S
    if entry.rain_history_h_mm_h is None:
        return History.constant((entry.rain_mm_h or 0.0) * MM_H_TO_M_S - evaporation_m_s)
    times, values = [], []
    if entry.rain_history_h_mm_h[0][0] > 0.0:
        times, values = [0.0], [0.0]
    for t_h, intensity in entry.rain_history_h_mm_h:
        if times:
            times.append(t_h * HOUR_S)
            values.append(values[-1])
        times.append(t_h * HOUR_S)
        values.append(intensity * MM_H_TO_M_S)
    return History(np.array(times), np.array(values) - evaporation_m_s)


def level_history(entry) -> History:
    """A reservoir's level (m) against time (s), linear between its points."""
    points = np.array(entry.level_history_h_m, dtype=float)
    return History(points[:, 0] * HOUR_S, points[:, 1])


def output_times_h(transient, until_h: float | None = None) -> np.ndarray:
    """The times the flow is saved at (h, > 0): the FOS's, water_at_h, and ``saved_times`` evenly spaced; with
    ``until_h`` those up to it and the first after (the flow need go no further to give the water then)."""
    listed = list(transient.fos_times()) + ([transient.water_at_h] if transient.water_at_h is not None else [])
    listed += list(np.linspace(0.0, transient.end_time_h, transient.saved_times + 1)[1:])
    times = np.unique(np.round(np.array(listed, dtype=float), 9))
    times = times[times > 0.0]
    if until_h is not None:
        times = times[:max(1, int(np.searchsorted(times, until_h + 1e-9)))]
    return times


def transient_flow(study, until_h: float | None = None) -> TransientFlow:
    """The transient flow of ``study`` (module doc), to ``end_time_h`` or only as far as the water at
    ``until_h`` needs; StudyError naming the field when it cannot be solved."""
    start = time.perf_counter()
    transient = study.transient
    geometry, materials = study.geometry, study.materials
    node_xy_m, node_spacing_m = cloud_of_geometry(geometry)
    spacing = node_spacing_m if geometry.refined else geometry.spacing_m
    elem_nodes = triangulate(node_xy_m, spacing, study.solver.alpha).elem_nodes
    node_material = rows_of_materials(materials, node_xy_m)
    centroid_material = rows_of_materials(materials, node_xy_m[elem_nodes].mean(axis=1))
    majority = np.array([np.bincount(rows).argmax() for rows in node_material[elem_nodes]])
    elem_material = np.where(centroid_material >= 0, centroid_material, majority)
    k1 = np.array([m.permeability_m_s for m in materials])[elem_material]
    ratio = np.array([m.permeability_ratio for m in materials])[elem_material]
    angle = np.array([m.permeability_angle_deg for m in materials])[elem_material]
    curves_by_name = {entry.material: curve_of(entry) for entry in transient.curves}
    curves = tuple(curves_by_name[m.name] for m in materials)

    n = node_xy_m.shape[0]
    finest_m = float(np.min(node_spacing_m))
    edges = boundary_edges(elem_nodes)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[edges.ravel()] = True
    boundaries: list[FluxBoundary | ReservoirBoundary | SeepageFace | HeadBoundary] = []
    reservoirs: list = []
    initial = _initial_head_m(study, node_xy_m)
    for i, entry in enumerate(transient.boundary):
        where = f"transient.boundary[{i}]"
        box = on_boundary & entry.holds(node_xy_m, finest_m)
        if not box.any():
            raise StudyError(where, f"the box of {entry.name!r} holds no particle of the domain's boundary")
        if entry.condition == "rain":
            selected = edges[box[edges[:, 0]] & box[edges[:, 1]]]
            weights = boundary_flux_weights_m(node_xy_m, selected, entry.rain_direction == "horizontal")
            if not np.any(weights > 0.0):
                raise StudyError(where, f"the box of {entry.name!r} holds no edge of the domain's boundary the rain "
                                 "falls on (a flux needs two neighbouring boundary particles, not on one vertical)")
            dry_limit_m = None if entry.evaporation_mm_h is None else entry.surface_min_head_m
            boundaries.append(FluxBoundary(entry.name, weights, rain_history(entry), dry_limit_m=dry_limit_m))
        elif entry.condition == "reservoir":
            history = level_history(entry)
            slack = POND_SLACK * geometry.finest_spacing_m
            span = (-np.inf if entry.x_min_m is None else entry.x_min_m - slack,
                    np.inf if entry.x_max_m is None else entry.x_max_m + slack)
            x = node_xy_m[:, 0]
            ground_m = surface_height_m(np.asarray(geometry.polygon_m, dtype=float), x)
            ground_m = np.where((x >= span[0]) & (x <= span[1]) & np.isfinite(ground_m), ground_m, np.inf)
            boundaries.append(ReservoirBoundary(entry.name, box, history, ground_m, entry.loading_efficiency))
            reservoirs.append((history, span))
        elif entry.condition == "seepage_face":
            boundaries.append(SeepageFace(entry.name, box))
        elif entry.condition == "total_head":
            boundaries.append(HeadBoundary(entry.name, box, History.constant(entry.total_head_m)))
        elif entry.condition == "pressure_head":
            boundaries.append(HeadBoundary(entry.name, box, History.constant(entry.pressure_head_m or 0.0),
                                           pressure=True))
        else:  # no_flow: takes its particles from the entries before
            boundaries.append(SeepageFace(entry.name, np.zeros(n, dtype=bool)))
            for b, earlier in enumerate(boundaries[:-1]):
                boundaries[b] = _without(earlier, box)
    _check_dry_limits(transient.boundary, boundaries, initial - node_xy_m[:, 1])
    boundaries = [b for b in boundaries if np.any(b.nodes)]
    _check_initial_water_under_ground(study, node_xy_m, edges, initial, reservoirs, finest_m)
    problem = TransientProblem(node_xy_m, elem_nodes, conductivity_tensor(k1, k1 * ratio, angle), elem_material,
                               curves, tuple(boundaries), initial)
    settings = TransientSettings(initial_step_s=min(60.0, transient.max_step_h * HOUR_S),
                                 max_step_s=transient.max_step_h * HOUR_S)
    try:
        solution = solve_transient_flow(problem, output_times_h(transient, until_h) * HOUR_S, settings)
    except FlowNotConverged as error:
        raise StudyError("transient", f"{error} (a finer spacing, a shorter max_step_h, or a smaller rain or "
                         "permeability contrast)") from None
    water = study.water
    gamma_w = DEFAULT_WATER_UNIT_WEIGHT_N_M3 if water is None else water.unit_weight_n_m3
    return TransientFlow(node_xy_m, elem_nodes, elem_material, problem, solution, tuple(reservoirs), gamma_w,
                         transient.suction_in_strength, time.perf_counter() - start)


def _check_dry_limits(entries, boundaries: list, pressure_head_m: np.ndarray) -> None:
    """StudyError naming its ``surface_min_head_m`` when the initial pressure head on the particles a rain entry
    that evaporates at some time holds (those no later entry takes) is below its dry limit: held there, the surface would wet the
    ground.  ``boundaries``: one per entry, in order (``transient_flow``)."""
    taken_later = np.zeros(pressure_head_m.size, dtype=bool)
    for i in reversed(range(len(boundaries))):
        boundary = boundaries[i]
        if isinstance(boundary, FluxBoundary) and boundary.dry_limit_m is not None and np.any(
                boundary.flux_m_s.values < 0.0):  # it evaporates at some time
            surface = boundary.nodes & ~taken_later
            driest_m = float(pressure_head_m[surface].min(initial=np.inf))
            if driest_m < boundary.dry_limit_m:
                raise StudyError(f"transient.boundary[{i}].surface_min_head_m",
                                 f"{boundary.dry_limit_m:g} m is above the initial pressure head on the surface of "
                                 f"{entries[i].name!r} (down to {driest_m:.4g} m): give a lower limit, or a "
                                 f"suction_limit_m of at most {-boundary.dry_limit_m:g} m")
        taken_later |= boundary.nodes


def _without(boundary, nodes: np.ndarray):
    """``boundary`` less the particles ``nodes`` (a later no_flow entry takes them)."""
    if isinstance(boundary, FluxBoundary):
        return FluxBoundary(boundary.name, np.where(nodes, 0.0, boundary.node_weight_m), boundary.flux_m_s,
                            boundary.ponds, boundary.dry_limit_m)
    kept = boundary.nodes & ~nodes
    if isinstance(boundary, ReservoirBoundary):
        return ReservoirBoundary(boundary.name, kept, boundary.level_m, boundary.ground_above_m,
                                 boundary.loading_efficiency)
    if isinstance(boundary, HeadBoundary):
        return HeadBoundary(boundary.name, kept, boundary.head_m, boundary.pressure, boundary.offset_m)
    return SeepageFace(boundary.name, kept)


def _initial_head_m(study, node_xy_m: np.ndarray) -> np.ndarray:
    """Hydrostatic below the initial water table (not below -suction_limit_m), or the steady flow's heads."""
    transient = study.transient
    if transient.initial_state == "steady":
        from workflows.seepage.flow import study_flow  # only for a study that starts from it

        steady = study_flow(study)
        return steady.solution.head_m.copy()
    if transient.initial_water_line_m is not None:
        line = np.array(transient.initial_water_line_m)
        table_m = np.interp(node_xy_m[:, 0], line[:, 0], line[:, 1])
    else:
        table_m = transient.initial_water_table_m
    return hydrostatic_head_m(node_xy_m, table_m, transient.suction_limit_m)


def _check_initial_water_under_ground(study, node_xy_m: np.ndarray, edges: np.ndarray, head_m: np.ndarray,
                                      reservoirs: list, finest_m: float) -> None:
    """StudyError when the initial water table stands more than a spacing above the ground surface where no
    reservoir holds water at 0 h: the ground there would carry a pore pressure no water above it holds (its
    effective stress tensile from the first step), as the steady flow refuses (``seepage.flow``)."""
    transient = study.transient
    if transient.initial_state != "water_table":
        return  # the steady flow's heads: its own check
    polygon = np.asarray(study.geometry.polygon_m, dtype=float)
    surface = np.unique(edges.ravel())
    x, y = node_xy_m[surface, 0], node_xy_m[surface, 1]
    ground_m = surface_height_m(polygon, x)
    on_ground = np.isfinite(ground_m) & (y >= ground_m - TOLERANCE_PER_SPACING * finest_m)
    excess_m = np.where(on_ground, head_m[surface] - y, -np.inf)
    for history, (x_min, x_max) in reservoirs:
        excess_m[(x >= x_min) & (x <= x_max) & (head_m[surface] <= history.at(0.0) + finest_m)] = -np.inf
    k = int(np.argmax(excess_m))
    if excess_m[k] > study.geometry.spacing_m:
        field = "initial_water_table_m" if transient.initial_water_line_m is None else "initial_water_line_m"
        raise StudyError(f"transient.{field}", (
            f"the water stands {excess_m[k]:.3g} m above the ground surface at ({x[k]:.4g}, {y[k]:.4g}) m at 0 h "
            "where no reservoir holds it: the ground there would carry a pore pressure no water above it holds; "
            "draw the table at or below the ground, or give the water standing on it as a reservoir "
            "([[transient.boundary]] condition = \"reservoir\")"))


def water_at_time(study, time_h: float | None = None) -> WaterAt:
    """The water the stages of ``study`` see: its flow solved to ``time_h`` and taken there (default
    ``water_at_h``; for the FOS against time, its first time: what its section shows)."""
    time_h = study.transient.water_time_h if time_h is None else time_h
    return transient_flow(study, until_h=time_h).water_at(time_h)



def scene_fields(study, node_xy_m: np.ndarray, node_material: np.ndarray, water: WaterAt) -> dict:
    """Keyword arguments of ``spfem_core.scene.Scene`` for the ``water`` of a study with ``[transient]``: the
    pore pressure (with suction) carried by each particle, the saturated density at or below the water
    table, and the water of the first reservoir standing on the surface at that time."""
    if water.node_xy_m.shape != node_xy_m.shape or not np.array_equal(water.node_xy_m, node_xy_m):
        raise ValueError("transient: the flow was solved on another cloud than the scene's (a bug)")
    fields = dict(node_pore_pressure_pa=water.pore_pressure_pa(), water_unit_weight_n_m3=water.water_unit_weight_n_m3)
    if any(m.saturated_density_kg_m3 is not None for m in study.materials):
        fields["node_properties"] = {"density_kg_m3": densities(study, node_material, water.saturated())}
    if water.reservoir_levels:
        level_m, span_m = water.reservoir_levels[0]
        fields.update(pond_level_m=level_m, pond_x_range_m=span_m)
    return fields
