"""From a study's ``[water]`` and ``[loads]`` to what the core applies: densities below the
piezometric line, ru pore pressures, surface-load forces on the particles, the seismic body force.

Surface loads act on the *upper surface* of the particle cloud: the boundary edges of its first
mesh whose outward normal points up (going a -> b with the material on the left, x_b < x_a).  A
strip load q on [x1, x2] puts q times the overlap of each such edge with [x1, x2] on the edge's
two particles, split by their linear shape functions (exact resultant and moment); a line load F at
x goes to the two particles of the edge above x the same way.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.mesh import boundary_edges, triangulate
from workflows.study import Study, StudyError

OVERBURDEN_SAMPLES = 64
"""Points per particle along the vertical to the surface when integrating the overburden (ru)."""


def surface_height_m(polygon, x: np.ndarray) -> np.ndarray:
    """Height of the polygon's highest edge above each abscissa ``x`` (NaN where none)."""
    xy = np.asarray(polygon, dtype=np.float64)
    start, end = xy, np.roll(xy, -1, axis=0)
    x = np.asarray(x, dtype=np.float64)[:, None]
    lo, hi = np.minimum(start[:, 0], end[:, 0]), np.maximum(start[:, 0], end[:, 0])
    spans = (x >= lo) & (x <= hi) & (hi > lo)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (x - start[:, 0]) / (end[:, 0] - start[:, 0])
        y = start[:, 1] + t * (end[:, 1] - start[:, 1])
    y = np.where(spans, y, -np.inf).max(axis=1)
    return np.where(np.isfinite(y), y, np.nan)


def phreatic_lines(study: Study, node_material: np.ndarray) -> tuple[tuple, np.ndarray]:
    """(the piezometric lines as (n_points, 2) arrays, the line of every particle: its material's own,
    else the study's, else -1)."""
    lines, material_line = [], np.full(len(study.materials), -1, dtype=np.int64)
    water = study.water
    if water is not None and water.phreatic_line is not None:
        lines.append(np.array(water.phreatic_line))
        material_line[:] = 0
    for i, material in enumerate(study.materials):
        if material.phreatic_line_m is not None:
            material_line[i] = len(lines)
            lines.append(np.array(material.phreatic_line_m))
    return tuple(lines), material_line[node_material]


def particle_densities(study: Study, node_xy_m: np.ndarray, node_material: np.ndarray) -> np.ndarray | None:
    """Density of every particle (kg/m3): its material's saturated density at or below its piezometric
    line, its density above; None when no material has a saturated density."""
    if all(m.saturated_density_kg_m3 is None for m in study.materials):
        return None
    dry = np.array([m.density_kg_m3 for m in study.materials])
    wet = np.array([m.density_kg_m3 if m.saturated_density_kg_m3 is None else m.saturated_density_kg_m3
                    for m in study.materials])
    lines, node_line = phreatic_lines(study, node_material)
    below = np.zeros(node_xy_m.shape[0], dtype=bool)
    for i, line in enumerate(lines):
        on = node_line == i
        below[on] = node_xy_m[on, 1] <= np.interp(node_xy_m[on, 0], line[:, 0], line[:, 1])
    return np.where(below, wet[node_material], dry[node_material])


def ru_pore_pressure_pa(study: Study, node_xy_m: np.ndarray, material_at, gravity_m_s2: float) -> np.ndarray:
    """u = ru sigma_v0 (Pa) of every particle: sigma_v0 = g int_y^{y_s(x)} rho dy, the weight of the
    column above it up to the ground surface y_s, with ``material_at(points)`` giving the material
    row of points (the midpoint rule on ``OVERBURDEN_SAMPLES`` points)."""
    top = surface_height_m(study.geometry.polygon_m, node_xy_m[:, 0])
    depth = np.maximum(np.nan_to_num(top - node_xy_m[:, 1]), 0.0)
    fractions = (np.arange(OVERBURDEN_SAMPLES) + 0.5) / OVERBURDEN_SAMPLES
    sample_y = node_xy_m[:, 1:2] + depth[:, None] * fractions[None, :]
    points = np.stack([np.repeat(node_xy_m[:, 0], OVERBURDEN_SAMPLES), sample_y.ravel()], axis=1)
    density = np.array([m.density_kg_m3 for m in study.materials])[material_at(points)]
    overburden = gravity_m_s2 * density.reshape(-1, OVERBURDEN_SAMPLES).mean(axis=1) * depth
    return study.water.ru * overburden


def upper_surface_edges(node_xy_m: np.ndarray, spacing_m: float, alpha: float) -> np.ndarray:
    """Boundary edges (a, b) of the first mesh that face up (x_b < x_a: material below)."""
    edges = boundary_edges(triangulate(node_xy_m, spacing_m, alpha).elem_nodes)
    return edges[node_xy_m[edges[:, 1], 0] < node_xy_m[edges[:, 0], 0]]


def surface_load_forces(study: Study, node_xy_m: np.ndarray, spacing_m: float, alpha: float) -> np.ndarray | None:
    """(n, 2) forces (N/m) of the study's strip and line loads on the particles (module doc); None
    without loads.  A load that reaches no upper-surface edge is a StudyError."""
    strips, lines = study.loads.strip, study.loads.line
    if not strips and not lines:
        return None
    edges = upper_surface_edges(node_xy_m, spacing_m, alpha)
    xa, xb = node_xy_m[edges[:, 0], 0], node_xy_m[edges[:, 1], 0]
    force = np.zeros_like(node_xy_m)
    for i, strip in enumerate(strips):
        lo = np.clip(strip.x_start_m, xb, xa)
        hi = np.clip(strip.x_end_m, xb, xa)
        # int_lo^hi N_a dx with N_a = (x - x_b) / (x_a - x_b); N_b = 1 - N_a
        on_a = ((hi - xb) ** 2 - (lo - xb) ** 2) / (2.0 * (xa - xb))
        on_b = (hi - lo) - on_a
        if not np.any(hi > lo):
            raise StudyError(f"loads.strip[{i}]", f"{strip.name!r} reaches no particle of the ground surface")
        np.add.at(force[:, 1], edges[:, 0], -strip.pressure_pa * on_a)
        np.add.at(force[:, 1], edges[:, 1], -strip.pressure_pa * on_b)
    for i, line in enumerate(lines):
        holding = np.flatnonzero((xb <= line.x_m) & (line.x_m <= xa))
        if holding.size == 0:
            raise StudyError(f"loads.line[{i}].x_m", f"{line.x_m:g} m: no ground surface above this abscissa")
        e = holding[0]
        share_a = (line.x_m - xb[e]) / (xa[e] - xb[e])
        force[edges[e, 0], 1] -= line.force_n_m * share_a
        force[edges[e, 1], 1] -= line.force_n_m * (1.0 - share_a)
    return force


def downslope_sign(polygon_m) -> float | None:
    """+1 when the ground surface is lower at the right end of the domain than at the left, -1 when
    it is lower at the left, None when both ends are as high."""
    xs = [x for x, _ in polygon_m]
    left, right = surface_height_m(polygon_m, np.array([min(xs), max(xs)]))
    if math.isclose(left, right, rel_tol=0.0, abs_tol=1e-9 * (1.0 + abs(left))):
        return None
    return 1.0 if right < left else -1.0


def seismic_direction(study: Study, direction: str | None = None) -> float:
    """+1 or -1: the x direction of the horizontal seismic force (``direction``, by default
    ``loads.seismic.direction``); ``out_of_slope`` is :func:`downslope_sign`."""
    direction = direction or study.loads.seismic.direction
    if direction != "out_of_slope":
        return 1.0 if direction == "+x" else -1.0
    sign = downslope_sign(study.geometry.polygon_m)
    if sign is None:
        raise StudyError("loads.seismic.direction", "the ground surface is as high at both ends of the domain, so "
                         "out_of_slope has no meaning here: give +x or -x")
    return sign


def body_acceleration_m_s2(study: Study, strength_reduction: bool) -> np.ndarray:
    """Gravity plus the pseudo-static seismic acceleration (kh g towards the face, kv g up) where it
    applies: in strength-reduction runs, and in the stages before with ``in_gravity``."""
    gravity = np.array(study.loads.gravity_m_s2, dtype=np.float64)
    seismic = study.loads.seismic
    if seismic is None or not (strength_reduction or seismic.in_gravity):
        return gravity
    g = float(np.hypot(*gravity))
    return gravity + np.array([seismic_direction(study) * seismic.horizontal_coefficient * g,
                               seismic.vertical_coefficient * g])


def water_scene_fields(study: Study, node_xy_m: np.ndarray, node_material: np.ndarray, material_at) -> dict:
    """Keyword arguments of ``Scene`` for the study's water (empty without ``[water]`` and without a
    material's own piezometric line)."""
    water = study.water
    if water is None and all(m.phreatic_line_m is None for m in study.materials):
        return {}
    lines, node_line = phreatic_lines(study, node_material)
    fields = dict(phreatic_lines_m=lines, node_phreatic_line=node_line,
                  node_density_kg_m3=particle_densities(study, node_xy_m, node_material))
    if water is None:
        return fields
    fields.update(water_unit_weight_n_m3=water.unit_weight_n_m3, pond_level_m=water.pond_level_m)
    if water.ru is not None:
        g = float(np.hypot(*study.loads.gravity_m_s2))
        fields["node_pore_pressure_pa"] = ru_pore_pressure_pa(study, node_xy_m, material_at, g)
    return fields


def stage_water(study: Study, stage, node_material: np.ndarray):
    """(piezometric lines, line of each particle, pond level or None) of a stage: the study's water,
    or the stage's own ``phreatic_level_m`` / ``pond_level_m`` (a runout triggered by water)."""
    lines, node_line = phreatic_lines(study, node_material)
    pond = None if study.water is None else study.water.pond_level_m
    level = getattr(stage, "phreatic_level_m", None)
    if level is not None:
        lines = lines + (np.array([[-1e9, level], [1e9, level]]),)
        own = np.array([m.phreatic_line_m is not None for m in study.materials])[node_material]
        node_line = np.where(own, node_line, len(lines) - 1)
    if getattr(stage, "pond_level_m", None) is not None:
        pond = stage.pond_level_m
    return lines, node_line, pond


def stage_acceleration_m_s2(study: Study, stage) -> np.ndarray:
    """The body acceleration of a stage before the strength reduction: the study's (gravity, and the
    seismic load with ``in_gravity``), or gravity with the stage's own ``horizontal_coefficient``
    out of the slope (a runout triggered by an earthquake)."""
    kh = getattr(stage, "horizontal_coefficient", None)
    if kh is None:
        return body_acceleration_m_s2(study, strength_reduction=False)
    gravity = np.array(study.loads.gravity_m_s2, dtype=np.float64)
    return gravity + np.array([seismic_direction(study, "out_of_slope") * kh * float(np.hypot(*gravity)), 0.0])
