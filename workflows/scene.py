"""From a checked :class:`~workflows.study.Study` to the core's ``Scene`` and ``SolverSettings``.

The particles fill the polygon and take their materials (``workflows.particles``), whose rooms give
the core their rows (``workflows.materials``); the surface loads put their forces on the upper
surface (``workflows.loads``); the water gives its lines, pressures and saturated densities
(``workflows.water.pressure``), from the study's steady flow with ``[seepage]`` (``workflows.seepage.flow``:
given by the caller that has it, else solved here); the ``[[boundary]]`` boxes fix velocities.

Problems that only show once the particles exist (a boundary box that holds no particle,
particles outside every material region) raise :class:`~workflows.study.StudyError`,
like the file checks, before anything is run or written.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from spfem_core.geometry import points_in_polygon
from spfem_core.materials.table import MaterialTable
from spfem_core.scene import Scene
from spfem_core.settings import DEFAULT_CFL, SolverSettings
from workflows.loads.surface import UpperSurface
from workflows.particles import assign_materials, cloud, material_rows
from workflows.random_field.table import SEEPAGE_PROPERTY
from workflows.random_field.values import field_notes, node_properties
from workflows.seepage.flow import StudyFlow, study_flow
from workflows.study import Study, StudyError
from workflows.transient.flow import WaterAt, water_at_time
from workflows.transient.flow import scene_fields as transient_scene_fields
from workflows.water.pressure import scene_fields


def build_material_table(study: Study) -> MaterialTable:
    """One row per ``[[materials]]`` entry, in file order, as each model's room translates it."""
    return MaterialTable.from_rows([material.core_row() for material in study.materials])


def surface_load_forces(study: Study, node_xy_m: np.ndarray, node_spacing_m: np.ndarray) -> np.ndarray | None:
    """(n, 2) forces (N/m) of the study's surface loads on the particles of the cloud's upper surface,
    kind after kind (``workflows.loads``); None without surface loads."""
    loads = study.loads.surface_loads()
    if not loads:
        return None
    surface = UpperSurface.of_cloud(node_xy_m, node_spacing_m, study.solver.alpha)
    force = np.zeros_like(node_xy_m)
    for where, load in loads:
        load.add_forces(surface, force, where)
    return force


def field_values(study: Study, node_xy_m: np.ndarray | None = None, node_spacing_m: np.ndarray | None = None,
                 node_material: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Every property a ``[random_field]`` varies (the permeability of the flow too) at the study's
    particles (its cloud, unless given), NaN at the particles of other materials."""
    if node_xy_m is None:
        node_xy_m, node_spacing_m = cloud(study)
        node_material = assign_materials(study, node_xy_m)
    return node_properties(study.random_field, study.materials, node_xy_m, node_spacing_m, node_material)


def random_field_notes(study: Study) -> list[str]:
    """A line per random field not drawn exactly by circulant embedding (``random_field.values.field_notes``);
    none without ``[random_field]``."""
    if study.random_field is None:
        return []
    node_xy_m, node_spacing_m = cloud(study)
    return field_notes(study.random_field, study.materials, node_xy_m, node_spacing_m,
                       assign_materials(study, node_xy_m))


def build_scene(study: Study, flow=None) -> Scene:
    """The particle cloud of ``study`` with its materials, supports, gravity (with the seismic part when
    it acts from the first stage), water and surface loads (:func:`scene_and_flow`)."""
    return scene_and_flow(study, flow)[0]


@functools.lru_cache(maxsize=2)
def water_flow(study: Study) -> StudyFlow | WaterAt | None:
    """The flow a study's water comes from: with ``[transient]`` its water at the study's time
    (``workflows.transient.flow``), with ``[seepage]`` its steady flow; None without either.  Solved once
    per process for a study (an equal study is the same flow): the report's section drawn after the run
    solved it again (seepage_perched: 4.5 s of its 17 s).  Read-only to its callers."""
    if study.transient is not None:
        return water_at_time(study)
    return study_flow(study) if study.seepage is not None else None


def scene_and_flow(study: Study, flow=None) -> tuple[Scene, StudyFlow | WaterAt | None]:
    """(the scene of :func:`build_scene`, the flow its water comes from, or None without ``[seepage]``
    or ``[transient]``: :func:`water_flow`).  ``flow``: the study's flow when the caller has it; else it
    is solved here, once the particles have their materials."""
    geometry = study.geometry
    node_xy_m, node_spacing_m = cloud(study)
    if node_xy_m.shape[0] < 3:
        raise StudyError("geometry.spacing_m", f"gives {node_xy_m.shape[0]} particles; make it smaller")
    node_material = assign_materials(study, node_xy_m)
    if flow is None:
        flow = water_flow(study)
    if study.transient is not None:
        water_fields = transient_scene_fields(study, node_xy_m, node_material, flow)
    else:
        water_fields = scene_fields(study, node_xy_m, node_material, lambda points: material_rows(study, points), flow)
    if study.random_field is not None:  # spatially variable soil (workflows.random_field.values)
        varying = field_values(study, node_xy_m, node_spacing_m, node_material)
        varying.pop(SEEPAGE_PROPERTY, None)  # the flow's (workflows.seepage.flow), not the core's
        water_fields["node_properties"] = {**water_fields.get("node_properties", {}), **varying}
    scene = Scene(
        node_xy_m=node_xy_m,
        node_material=node_material,
        materials=build_material_table(study),
        spacing_m=geometry.finest_spacing_m,
        node_spacing_m=node_spacing_m if geometry.refined else None,
        gravity_m_s2=study.loads.acceleration_m_s2(geometry.polygon_m, strength_reduction=False),
        alpha=study.solver.alpha,
        node_load_n=surface_load_forces(study, node_xy_m, node_spacing_m),
        **water_fields,
    )
    for i, wall in enumerate(study.walls):
        behind = particles_behind_wall(node_xy_m, wall.start_m, wall.end_m, WALL_GAP_TOLERANCE * scene.spacing_m)
        if behind.size:
            x_m, y_m = node_xy_m[behind[0]]
            raise StudyError(f"walls[{i}]", f"{behind.size} particles lie behind {wall.name!r} (the first at "
                             f"({x_m:g}, {y_m:g}) m): the material must lie on the wall's left going from start_m "
                             "to end_m, so a wall may run along the soil, not through it (or swap start_m and end_m)")
        (x1_m, y1_m), (x2_m, y2_m) = wall.start_m, wall.end_m
        scene.add_wall(x1_m, y1_m, x2_m, y2_m, friction=wall.friction)
    for i, boundary in enumerate(study.boundary):
        if _boundary_nodes(scene, boundary).size == 0:
            raise StudyError(f"boundary[{i}]", f"the box of {boundary.name!r} holds no particle")
    held = supports(study, scene)
    scene.node_fixed, scene.node_fixed_velocity_m_s = held.fixed, held.velocity_m_s
    scene.node_slip_length_m, scene.node_slip_side = held.slip_length_m, held.slip_side
    counts = np.bincount(node_material, minlength=len(study.materials))
    for i in range(len(study.materials)):
        if counts[i] == 0:
            raise _no_particle(study, i)
    for i, stage in enumerate(study.stages):
        active = supports(study, scene, stage.boundary)
        field = f"stages[{i}].boundary" if stage.boundary is not None else "boundary"
        if active.fixed.all():
            raise StudyError(field, f"the supports of stage {stage.name!r} prescribe both velocities of every "
                             "particle: nothing is free to deform; make the boxes hold the base and sides only")
        # a slip support holds its tangential direction by the soil's friction
        free = "" if study.walls else rigid_motion_left(node_xy_m, active.fixed | (active.slip_length_m > 0.0)[:, None])
        if free:
            raise StudyError(field, f"the supports of stage {stage.name!r} leave the body free to {free}: it "
                             "would fall or drift as a whole; fix a base (vx_m_s = vy_m_s = 0) or add rollers")
    return scene, flow


def _no_particle(study: Study, index: int) -> StudyError:
    """The error of a material that holds no particle, on the field that placed it (its region_m, or
    the section's layer), with why: its region lies outside the domain, or inside it but thinner
    than the spacing there (or under the materials after it)."""
    material = study.materials[index]
    field = f"materials[{index}]"
    section = study.geometry.section
    for j, layer in enumerate(section.layers if section is not None else ()):
        if layer.material == material.name:
            field = f"geometry.section.layers[{j}]"
    region, polygon = np.array(material.region_m), np.array(study.geometry.polygon_m)
    if not (points_in_polygon(region, polygon).any() or points_in_polygon(polygon, region).any()):
        why = "its region lies outside geometry.polygon_m"
    else:
        geometry = study.geometry
        spacing = (f"{geometry.spacing_m:g} m" if not geometry.refined else
                   f"{geometry.finest_spacing_m:g} to {geometry.spacing_m:g} m")
        why = f"its region is thinner than the particle spacing there ({spacing}), or the materials after it cover it"
    return StudyError(field, f"{material.name!r} holds no particle: {why}; fix or remove it")


WALL_GAP_TOLERANCE = 1e-3
"""A particle lies behind a wall when its gap is below -WALL_GAP_TOLERANCE h (one on the wall is
in front)."""


def particles_behind_wall(node_xy_m: np.ndarray, start_m, end_m, tolerance_m: float) -> np.ndarray:
    """Indices of the particles within the wall's span (0 <= s <= 1) on its right, gap g < -tolerance,
    with s = (x - p1).t / L and g = (x - p1).n, n = (-(y2 - y1), x2 - x1) / L pointing into the
    material (``spfem_core.contact``)."""
    p1, p2 = np.asarray(start_m, dtype=float), np.asarray(end_m, dtype=float)
    length_m = float(np.hypot(*(p2 - p1)))
    tangent = (p2 - p1) / length_m
    normal = np.array([-tangent[1], tangent[0]])
    offset = node_xy_m - p1
    s = offset @ tangent / length_m
    gap_m = offset @ normal
    return np.flatnonzero((s >= 0.0) & (s <= 1.0) & (gap_m < -tolerance_m))


def rigid_motion_left(node_xy_m: np.ndarray, fixed: np.ndarray) -> str:
    """Which rigid motion of the cloud its prescribed directions ``fixed`` (n, 2) leave free ("" for
    none).  A rigid velocity is v = (a - w y, b + w x): a fixed x at particle k asks a - w y_k = 0,
    a fixed y asks b + w x_k = 0; the motion is held when these rows have rank 3."""
    fixed_x, fixed_y = fixed[:, 0], fixed[:, 1]
    if not fixed_x.any() and not fixed_y.any():
        return "move in any direction"
    if not fixed_x.any():
        return "move horizontally"
    if not fixed_y.any():
        return "move vertically"
    centre = node_xy_m.mean(axis=0)
    size = max(float(np.ptp(node_xy_m, axis=0).max()), 1e-300)
    xy = (node_xy_m - centre) / size
    rows = np.concatenate([
        np.column_stack([np.ones(fixed_x.sum()), np.zeros(fixed_x.sum()), -xy[fixed_x, 1]]),
        np.column_stack([np.zeros(fixed_y.sum()), np.ones(fixed_y.sum()), xy[fixed_y, 0]]),
    ])
    if np.linalg.matrix_rank(rows.T @ rows, tol=1e-9) < 3:
        return "rotate"
    return ""


def _boundary_nodes(scene: Scene, boundary) -> np.ndarray:
    return scene.select_box(
        x_min=-np.inf if boundary.x_min_m is None else boundary.x_min_m,
        x_max=np.inf if boundary.x_max_m is None else boundary.x_max_m,
        y_min=-np.inf if boundary.y_min_m is None else boundary.y_min_m,
        y_max=np.inf if boundary.y_max_m is None else boundary.y_max_m,
    )


class Supports(NamedTuple):
    """What the ``[[boundary]]`` entries prescribe, per particle."""

    fixed: np.ndarray  # (n, 2) bool: velocity prescribed
    velocity_m_s: np.ndarray  # (n, 2) the prescribed velocity
    slip_length_m: np.ndarray  # (n,) share L_k of a slip support (0: none)
    slip_side: np.ndarray  # (n,) +-1: the side the slip support lies on along its prescribed direction; 0: none


def supports(study: Study, scene: Scene, active: tuple[str, ...] | None = None) -> Supports:
    """The ``[[boundary]]`` entries named in ``active`` (default: all), applied in file order.  A
    slip support (:func:`slip_normal`) holds only its normal direction; its particles lie on one
    line across that direction: each gets half the distance between its neighbours along the line
    (an end particle half the gap to its one neighbour) and the side the support lies on, away from
    the body's centroid.  A particle that ends with both directions prescribed (a corner shared with
    another support) is not a slip one."""
    n = scene.n_particles
    fixed = np.zeros((n, 2), dtype=bool)
    velocity = np.zeros((n, 2))
    slip_length, slip_side = np.zeros(n), np.zeros(n)
    for boundary in study.boundary:
        if active is not None and boundary.name not in active:
            continue
        nodes = _boundary_nodes(scene, boundary)
        normal = slip_normal(scene.node_xy_m, scene.spacing_m, boundary, nodes)
        for d, value in enumerate((boundary.vx_m_s, boundary.vy_m_s)):
            if value is not None and (normal is None or d == normal):
                fixed[nodes, d] = True
                velocity[nodes, d] = value
        if normal is not None:
            slip_length[nodes], slip_side[nodes] = _slip_shares(scene, nodes, normal, boundary.name)
        else:
            slip_length[nodes], slip_side[nodes] = 0.0, 0.0
    corner = fixed.all(axis=1)
    slip_length[corner], slip_side[corner] = 0.0, 0.0
    return Supports(fixed, velocity, slip_length, slip_side)


def slip_normal(node_xy_m: np.ndarray, spacing_m: float, boundary, nodes: np.ndarray) -> int | None:
    """The direction a slip support holds (0: x, 1: y), or None for a support that is not one: the
    answer of its kind of slip (``workflows.study.supports.SLIP_KINDS``: ``soil``, ``welded``, ``none``,
    or left out: a rough rigid base where it holds both velocities at 0 along one horizontal or vertical
    line, docs/method.md section 3), given the line its particles lie on."""
    on_line = [d for d in (1, 0) if nodes.size >= 2 and np.ptp(node_xy_m[nodes, d]) <= 1e-3 * spacing_m]
    return boundary.slip_kind.held_direction(boundary, on_line[0] if on_line else None)


def _slip_shares(scene: Scene, nodes: np.ndarray, normal: int, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(L_k, side) of a slip support's particles ``nodes`` (:func:`supports`)."""
    xy = scene.node_xy_m
    across = xy[nodes, normal]
    if np.ptp(across) > 1e-3 * scene.spacing_m:
        raise StudyError("boundary", f"the slip support {name!r} must select particles on one straight line "
                         f"{'x' if normal == 0 else 'y'} = const; its particles span {np.ptp(across):.3g} m across it")
    along = xy[nodes, 1 - normal]
    order = np.argsort(along, kind="stable")
    sorted_along = along[order]
    if nodes.size < 2:
        raise StudyError("boundary", f"the slip support {name!r} holds {nodes.size} particle; it needs two at least")
    padded = np.concatenate([[sorted_along[0]], sorted_along, [sorted_along[-1]]])
    length = np.empty(nodes.size)
    length[order] = 0.5 * (padded[2:] - padded[:-2])
    side = 1.0 if across.mean() > xy[:, normal].mean() else -1.0
    return length, np.full(nodes.size, side)


def solver_settings(study: Study, threads: int = 0) -> SolverSettings:
    """Time step rule and stabilisation of ``study``; the compiled step on ``threads`` threads
    (0: all cores, for a study's single runs; 1 on a dask worker, which shares its cores with
    the other workers' runs)."""
    solver = study.solver
    cfl = DEFAULT_CFL if solver.cfl is None else solver.cfl
    return SolverSettings(
        cfl=cfl, dt_s=solver.dt_s, stabilisation_beta=solver.stabilisation_beta,
        min_angle_deg=solver.remesh_min_angle_deg, threads=threads, density_scaling=solver.density_scaling,
        uniform_relaxation_step=solver.uniform_relaxation_step,
    )


def monitor_particles(study: Study, scene: Scene) -> np.ndarray:
    """Index of the particle nearest to each monitor point, in ``[[monitors]]`` order (int64)."""
    return np.array([scene.nearest_particle(m.x_m, m.y_m) for m in study.monitors], dtype=np.int64)
