"""A study's steady flow: its problem on the particles' first mesh, solved, and what it does to the
particles.

1. The mesh is the simulation's first mesh of the study's cloud (``workflows.particles.cloud``,
   ``spfem_core.mesh.triangulate``); a triangle takes the conductivity of the material whose region
   holds its centroid (of the particles' material where the centroid lies in none).
2. The conditions (``workflows.seepage.table``): ponded water first, then each
   ``[[seepage.boundary]]`` entry in order, on the mesh's boundary particles inside its box; a flux
   goes to the nodes of the boundary edges both of whose ends it selects (half each, times the
   edge's length, or its horizontal length for infiltration).
3. ``spfem_core.seepage.solve_steady_flow`` finds the heads; where the ground cannot take the rain
   of an ``infiltration`` condition, its particles hold atmospheric pressure and the rest runs off.
   Water standing above the ground surface that no condition holds (a water table that reaches a
   no-flow or inflow part of the surface: no pond, no fixed head, no seepage face there) is refused,
   naming the ``[[seepage.boundary]]`` entry (:func:`_check_no_water_above_the_ground`).  Each
   particle then carries the pore pressure u = gamma_w max(h - y, 0) of its initial position (no
   suction above the water table), and weighs its material's saturated density where h >= y.

The pressure stays with the particles: a strength-reduction run starts from the gravity state at
the particles' initial positions and is judged by the displacement at which a mechanism forms,
well before the ground has moved far enough to change the flow; recomputing the flow on the
deformed mesh would need the boundary conditions of a surface that is no longer where the study
file put it (docs/method.md, section 15).

:func:`study_flow` solves it each time it is called and keeps nothing: whoever has the flow passes
it on as a value (the scene, the stage runner, the factor-of-safety engine, which ships it to its
workers with the gravity state; :func:`flow_inputs` tells which studies share one).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from spfem_core.geometry import surface_height_m
from spfem_core.mesh import boundary_edges, triangulate
from spfem_core.seepage import FlowProblem, FlowSolution, conductivity_tensor, head_scale_m, solve_steady_flow
from workflows.box import TOLERANCE_PER_SPACING
from workflows.fields import StudyError
from workflows.particles import cloud_of_geometry, rows_of_materials
from workflows.random_field.table import SEEPAGE_PROPERTY
from workflows.random_field.values import node_properties
from workflows.seepage.table import ROUND_OFF_SPACINGS

POND = "pond"
"""The name of ponded water's condition in the results."""
DEFAULT_WATER_UNIT_WEIGHT_N_M3 = 9810.0


@dataclass
class StudyFlow:
    """A study's flow problem on its particles and the solution."""

    node_xy_m: np.ndarray
    elem_nodes: np.ndarray
    elem_material: np.ndarray
    problem: FlowProblem
    solution: FlowSolution
    conditions: tuple[str, ...]  # the name of each condition: the pond (if any), then each entry
    node_condition: np.ndarray  # (n,) the condition that holds at each particle; -1: none (no flow or interior)
    water_unit_weight_n_m3: float
    wall_time_s: float

    def pore_pressure_pa(self) -> np.ndarray:
        """u = gamma_w max(h - y, 0) at every particle."""
        return self.water_unit_weight_n_m3 * np.maximum(self.solution.pressure_head_m(self.node_xy_m), 0.0)

    def saturated(self) -> np.ndarray:
        """Particles at or below the water table (h >= y)."""
        return self.solution.pressure_head_m(self.node_xy_m) >= 0.0

    def condition_inflow_m2_s(self) -> np.ndarray:
        """The water each condition takes in (m2/s per metre; negative: out), summed over its particles."""
        inflow = self.solution.node_inflow_m2_s
        return np.array([inflow[self.node_condition == i].sum() for i in range(len(self.conditions))])

    def runoff_m2_s(self) -> float:
        """The rain the ground does not take (m2/s per metre): the given inflow of the rain particles held
        at atmospheric pressure less what they take in."""
        held_rain = self.problem.infiltration() & self.solution.node_held & np.isnan(self.problem.node_fixed_head_m)
        return float((self.problem.node_inflow_m2_s[held_rain] - self.solution.node_inflow_m2_s[held_rain]).sum())


def flow_inputs(study) -> tuple:
    """What a study's flow depends on (equal inputs, equal flow): its geometry, materials, [seepage],
    ponded water, the alpha of its mesh, a [random_field] of permeability, and [transient] (with the time
    of its water)."""
    water = study.water
    field = study.random_field
    if field is not None and not any(entry.property == SEEPAGE_PROPERTY for entry in field.properties):
        field = None  # the flow does not depend on it: shared by every realisation
    return (study.geometry, study.materials, study.seepage, None if water is None else water.pond_level_m,
            None if water is None else (water.pond_x_min_m, water.pond_x_max_m),
            DEFAULT_WATER_UNIT_WEIGHT_N_M3 if water is None else water.unit_weight_n_m3, study.solver.alpha, field,
            study.transient)


def study_flow(study) -> StudyFlow:
    """The flow of ``study`` (module doc), solved from its :func:`flow_inputs`; StudyError naming the
    field for a problem that has no solution, or whose iteration does not converge."""
    return _flow(*flow_inputs(study)[:-1])


def _flow(geometry, materials, seepage, pond_level_m, pond_x_range_m, water_unit_weight_n_m3, alpha,
          random_field=None) -> StudyFlow:
    start = time.perf_counter()
    node_xy_m, node_spacing_m = cloud_of_geometry(geometry)
    spacing = node_spacing_m if geometry.refined else geometry.spacing_m
    elem_nodes = triangulate(node_xy_m, spacing, alpha).elem_nodes
    node_material = rows_of_materials(materials, node_xy_m)
    centroid_material = rows_of_materials(materials, node_xy_m[elem_nodes].mean(axis=1))
    majority = np.array([np.bincount(rows).argmax() for rows in node_material[elem_nodes]])
    elem_material = np.where(centroid_material >= 0, centroid_material, majority)
    k1 = np.array([m.permeability_m_s for m in materials])[elem_material]
    if random_field is not None:  # a permeability field: a triangle takes the geometric mean of its particles'
        node_k = node_properties(random_field, materials, node_xy_m, node_spacing_m, node_material)[SEEPAGE_PROPERTY]
        node_k = np.where(np.isnan(node_k), np.array([m.permeability_m_s for m in materials])[node_material], node_k)
        varies = np.isin(elem_material, [i for i, m in enumerate(materials) if any(
            e.material == m.name and e.property == SEEPAGE_PROPERTY for e in random_field.properties)])
        k1 = np.where(varies, np.exp(np.log(node_k[elem_nodes]).mean(axis=1)), k1)
    ratio = np.array([m.permeability_ratio for m in materials])[elem_material]
    angle = np.array([m.permeability_angle_deg for m in materials])[elem_material]
    conductivity = conductivity_tensor(k1, k1 * ratio, angle)

    n = node_xy_m.shape[0]
    finest_m = float(np.min(node_spacing_m))
    tol = TOLERANCE_PER_SPACING * finest_m
    edges = boundary_edges(elem_nodes)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[edges.ravel()] = True
    fixed_head = np.full(n, np.nan)
    face = np.zeros(n, dtype=bool)
    node_condition = np.full(n, -1, dtype=np.int64)
    flux_of = {}  # condition index -> (n,) its nodal inflow
    conditions: list = []
    x, y = node_xy_m[:, 0], node_xy_m[:, 1]
    if pond_level_m is not None:
        x_min, x_max = pond_x_range_m
        wet = on_boundary & (y <= pond_level_m + tol)
        wet &= (x >= (-np.inf if x_min is None else x_min) - tol) & (x <= (np.inf if x_max is None else x_max) + tol)
        fixed_head[wet] = pond_level_m
        node_condition[wet] = len(conditions)
        conditions.append(POND)
    for i, entry in enumerate(seepage.boundary):
        where = f"seepage.boundary[{i}]"
        box = on_boundary & entry.holds(node_xy_m, finest_m)
        if not box.any():
            raise StudyError(where, f"the box of {entry.name!r} holds no particle of the domain's boundary")
        index = len(conditions)
        conditions.append(entry.name)
        fixed_head[box], face[box] = np.nan, False
        node_condition[box] = index
        if entry.condition == "total_head":
            fixed_head[box] = entry.total_head_m
        elif entry.condition == "pressure_head":
            fixed_head[box] = y[box] + (entry.pressure_head_m or 0.0)
        elif entry.condition == "seepage_face":
            face[box] = True
        elif entry.condition in ("inflow", "infiltration"):
            selected = edges[box[edges[:, 0]] & box[edges[:, 1]]]
            if selected.size == 0:
                raise StudyError(where, f"the box of {entry.name!r} holds no edge of the domain's boundary "
                                 "(a flux needs two neighbouring boundary particles)")
            d = node_xy_m[selected[:, 1]] - node_xy_m[selected[:, 0]]
            length = np.abs(d[:, 0]) if entry.condition == "infiltration" else np.hypot(d[:, 0], d[:, 1])
            nodal = np.zeros(n)
            np.add.at(nodal, selected.ravel(), np.repeat(0.5 * entry.flux_m_s * length, 2))
            flux_of[index] = nodal
        else:  # no_flow
            node_condition[box] = -1
    inflow = np.zeros(n)
    rain = np.zeros(n, dtype=bool)
    for index, nodal in flux_of.items():
        mine = node_condition == index
        inflow[mine] = nodal[mine]
        if seepage.boundary[index - (pond_level_m is not None)].condition == "infiltration":
            rain |= mine & (nodal > 0.0)  # the particles the rain falls on (not those of a vertical side)
    _check_every_part_has_a_head(node_xy_m, elem_nodes, np.isfinite(fixed_head) | face)
    problem = FlowProblem(node_xy_m, elem_nodes, conductivity, fixed_head, inflow, face, seepage.residual_permeability,
                          seepage.unsaturated_band_m, node_infiltration=rain)
    try:
        solution = solve_steady_flow(problem, seepage.tolerance, seepage.max_iterations)
    except ValueError as error:
        raise StudyError("seepage.boundary", f"{error} (give a total_head, pressure_head or seepage_face "
                         "condition, or [water] pond_level_m)") from None
    if not solution.converged:
        largest_m = float(np.max(np.abs(solution.head_m)))
        round_off_m = ROUND_OFF_SPACINGS * math.ulp(largest_m)
        if solution.head_change_m[-1] <= round_off_m and seepage.tolerance * head_scale_m(problem) < round_off_m:
            suggested = 10.0 ** math.ceil(math.log10(round_off_m / head_scale_m(problem)))
            raise StudyError("seepage.tolerance", (
                f"{seepage.tolerance:g} is finer than the round-off of the heads: after {solution.iterations} "
                f"iterations they change by {solution.head_change_m[-1]:.2g} m, within {ROUND_OFF_SPACINGS} spacings "
                f"of doubles at heads of {largest_m:.3g} m, and no more iterations go below it; give at least "
                f"{suggested:g} (the default is 1e-6)"))
        raise StudyError("seepage.max_iterations", (
            f"the free surface did not settle in {solution.iterations} iterations (last head change "
            f"{solution.head_change_m[-1]:.3g} m); raise max_iterations, or give unsaturated_band_m (about "
            "1 m) where water infiltrates dry ground"))
    flow = StudyFlow(node_xy_m, elem_nodes, elem_material, problem, solution, tuple(conditions), node_condition,
                     float(water_unit_weight_n_m3), time.perf_counter() - start)
    _check_no_water_above_the_ground(flow, geometry, seepage, edges, finest_m)
    return flow


ABOVE_GROUND_PER_SPACING = 0.01
"""A particle of the ground surface whose pressure head exceeds this fraction of the finest spacing
has water standing above the ground (:func:`_check_no_water_above_the_ground`): well above the
iteration's own error, well below anything a pore pressure would notice."""


def _check_no_water_above_the_ground(flow: StudyFlow, geometry, seepage, edges: np.ndarray, finest_m: float) -> None:
    """StudyError naming the condition (or its absence) where the water table stands above the ground
    surface at a particle that no condition holds there: no ponded water, fixed head, seepage face or
    rain held at atmospheric pressure, so the water would stand on the ground with nothing to hold
    it (its pore pressure pulling the ground apart); the remedy is the condition that lets it out.
    The ground surface is the boundary edges on the polygon's upper boundary y_top(x), and its
    particles those whose every boundary edge is one (not where it meets the base or a side, whose
    particles carry a positive pressure below the water table as any particle there does)."""
    xy = flow.node_xy_m
    tol = TOLERANCE_PER_SPACING * finest_m
    middle = xy[edges].mean(axis=1)
    on_ground = np.all(xy[edges, 1] >= surface_height_m(geometry.polygon_m, xy[edges, 0].ravel()).reshape(-1, 2)
                       - tol, axis=1) & (middle[:, 1] >= surface_height_m(geometry.polygon_m, middle[:, 0]) - tol)
    surface = np.zeros(xy.shape[0], dtype=bool)
    surface[edges[on_ground].ravel()] = True
    surface[edges[~on_ground].ravel()] = False
    excess_m = np.where(surface & ~flow.solution.node_held, flow.solution.pressure_head_m(xy), -np.inf)
    k = int(np.argmax(excess_m))
    if not excess_m[k] > ABOVE_GROUND_PER_SPACING * finest_m:
        return
    x, y = xy[k]
    index = flow.node_condition[k]
    if index >= 0 and flow.conditions[index] != POND:
        i = [entry.name for entry in seepage.boundary].index(flow.conditions[index])
        where, what = f"seepage.boundary[{i}]", f"under {flow.conditions[index]!r} ({seepage.boundary[i].condition})"
    else:
        where, what = "seepage.boundary", "where the boundary is no-flow (a no_flow entry, or none)"
    raise StudyError(where, (
        f"the water stands {excess_m[k]:.3g} m above the ground surface at ({x:.4g}, {y:.4g}) m {what}: nothing "
        "holds water there; give that part of the surface a seepage_face (water leaves where it reaches the "
        "ground), an infiltration (rain the ground cannot take runs off) or the ponded water it carries"))


def _check_every_part_has_a_head(node_xy_m: np.ndarray, elem_nodes: np.ndarray, held: np.ndarray) -> None:
    """StudyError when a part of the mesh (particles joined by triangles) has no particle whose head a
    condition fixes: its heads would be undetermined (a singular system, not a number)."""
    n = node_xy_m.shape[0]
    edges = np.concatenate([elem_nodes[:, [0, 1]], elem_nodes[:, [1, 2]], elem_nodes[:, [2, 0]]])
    graph = coo_matrix((np.ones(edges.shape[0]), (edges[:, 0], edges[:, 1])), shape=(n, n))
    count, part = connected_components(graph, directed=False)
    anchored = np.zeros(count, dtype=bool)
    anchored[part[held]] = True
    if not anchored.all():
        x, y = node_xy_m[np.flatnonzero(~anchored[part])[0]]
        raise StudyError("seepage.boundary", f"no condition fixes a head on the part of the domain around "
                         f"({x:.3g}, {y:.3g}) m (give it a total_head, pressure_head or seepage_face condition)")
