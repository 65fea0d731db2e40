"""What the study's water (``workflows.water.table``) does to the particles of its scene.

- **Pore pressure** from a piezometric line y_w(x) (the study's, or a material's own perched
  line), u = gamma_w max(y_w(x) - y, 0), evaluated by the core at the particles' positions
  (``spfem_core.external_forces``); or from ``ru``, u = ru sigma_v0, carried by the particle:
  sigma_v0 = g int_y^{y_s(x)} rho dy, the weight of the column above its initial position up to
  the ground surface y_s (the midpoint rule on ``OVERBURDEN_SAMPLES`` points);
- **weight**: a material's saturated density at or below its piezometric line, its density above;
- **ponded water** at ``pond_level_m`` loads the current boundary (the core, ``external_forces``),
  between ``pond_x_min_m`` and ``pond_x_max_m``;
- **steady seepage** (``[seepage]``, ``workflows.seepage``) instead of a line: the flow's pore pressure
  carried by each particle, the saturated density where the particle is at or below the water table.

The line is fixed in space while the ground deforms.  :func:`scene_fields` gives the scene its
water; a stage may change it (``workflows.stages.base.StageBase.water``).
"""

from __future__ import annotations

import numpy as np

from spfem_core.geometry import surface_height_m

OVERBURDEN_SAMPLES = 64
"""Points per particle along the vertical to the surface when integrating the overburden (ru)."""


def phreatic_lines(study, node_material: np.ndarray) -> tuple[tuple, np.ndarray]:
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


def study_water(study, node_material: np.ndarray):
    """(piezometric lines, line of each particle, pond level or None) of the study: what a stage
    has unless it changes the water.  With ``[transient]`` the pond is its reservoir at the study's time."""
    lines, node_line = phreatic_lines(study, node_material)
    if study.transient is not None:
        return lines, node_line, study.transient.reservoir_level_m()
    return lines, node_line, None if study.water is None else study.water.pond_level_m


def particle_densities(study, node_xy_m: np.ndarray, node_material: np.ndarray) -> np.ndarray | None:
    """Density of every particle (kg/m3): its material's saturated density at or below its piezometric
    line, its density above; None when no material has a saturated density."""
    if all(m.saturated_density_kg_m3 is None for m in study.materials):
        return None
    lines, node_line = phreatic_lines(study, node_material)
    below = np.zeros(node_xy_m.shape[0], dtype=bool)
    for i, line in enumerate(lines):
        on = node_line == i
        below[on] = node_xy_m[on, 1] <= np.interp(node_xy_m[on, 0], line[:, 0], line[:, 1])
    return densities(study, node_material, below)


def densities(study, node_material: np.ndarray, saturated: np.ndarray) -> np.ndarray:
    """Density of every particle (kg/m3): its material's saturated density where ``saturated``, its
    density elsewhere (the saturated one defaults to it)."""
    dry = np.array([m.density_kg_m3 for m in study.materials])
    wet = np.array([m.density_kg_m3 if m.saturated_density_kg_m3 is None else m.saturated_density_kg_m3
                    for m in study.materials])
    return np.where(saturated, wet[node_material], dry[node_material])


def ru_pore_pressure_pa(study, node_xy_m: np.ndarray, material_at, gravity_m_s2: float) -> np.ndarray:
    """u = ru sigma_v0 (Pa) of every particle (module doc), with ``material_at(points)`` giving the
    material row of points."""
    top = surface_height_m(study.geometry.polygon_m, node_xy_m[:, 0])
    depth = np.maximum(np.nan_to_num(top - node_xy_m[:, 1]), 0.0)
    fractions = (np.arange(OVERBURDEN_SAMPLES) + 0.5) / OVERBURDEN_SAMPLES
    sample_y = node_xy_m[:, 1:2] + depth[:, None] * fractions[None, :]
    points = np.stack([np.repeat(node_xy_m[:, 0], OVERBURDEN_SAMPLES), sample_y.ravel()], axis=1)
    density = np.array([m.density_kg_m3 for m in study.materials])[material_at(points)]
    overburden = gravity_m_s2 * density.reshape(-1, OVERBURDEN_SAMPLES).mean(axis=1) * depth
    return study.water.ru * overburden


def seepage_fields(study, node_xy_m: np.ndarray, node_material: np.ndarray, flow) -> dict:
    """Scene fields of a study with ``[seepage]``: the pore pressure of its steady ``flow``
    (``workflows.seepage.flow.StudyFlow``) carried by each particle and, where a material has a
    saturated density, that density at or below the water table."""
    if flow.node_xy_m.shape != node_xy_m.shape or not np.array_equal(flow.node_xy_m, node_xy_m):
        raise ValueError("seepage: the flow was solved on another cloud than the scene's (a bug)")
    fields = dict(node_pore_pressure_pa=flow.pore_pressure_pa(), water_unit_weight_n_m3=flow.water_unit_weight_n_m3)
    if any(m.saturated_density_kg_m3 is not None for m in study.materials):
        fields["node_properties"] = {"density_kg_m3": densities(study, node_material, flow.saturated())}
    if study.water is not None and study.water.pond_level_m is not None:
        fields.update(pond_level_m=study.water.pond_level_m, pond_x_range_m=scene_pond_range(study))
    return fields


POND_SLACK = 0.5
"""The pond's abscissae are widened by this fraction of the spacing for the scene: a face the pond is
bounded by (pond_x_max_m at a vertical upstream face) stays wet as its particles move."""


def scene_pond_range(study) -> tuple[float, float]:
    """The pond's (x_min, x_max) as the core applies it (:data:`POND_SLACK`)."""
    x_min, x_max = study.water.pond_x_range_m
    slack = POND_SLACK * study.geometry.finest_spacing_m
    return x_min - slack, x_max + slack


def scene_fields(study, node_xy_m: np.ndarray, node_material: np.ndarray, material_at, flow=None) -> dict:
    """Keyword arguments of ``spfem_core.scene.Scene`` for the study's water (empty without ``[water]``,
    ``[seepage]`` and a material's own piezometric line); saturated densities as a per-particle density.
    ``flow``: the steady flow of a study with ``[seepage]``."""
    if study.seepage is not None:
        return seepage_fields(study, node_xy_m, node_material, flow)
    water = study.water
    if water is None and all(m.phreatic_line_m is None for m in study.materials):
        return {}
    lines, node_line = phreatic_lines(study, node_material)
    fields = dict(phreatic_lines_m=lines, node_phreatic_line=node_line)
    density = particle_densities(study, node_xy_m, node_material)
    if density is not None:
        fields["node_properties"] = {"density_kg_m3": density}
    if water is None:
        return fields
    fields.update(water_unit_weight_n_m3=water.unit_weight_n_m3, pond_level_m=water.pond_level_m,
                  pond_x_range_m=scene_pond_range(study))
    if water.ru is not None:
        g = float(np.hypot(*study.loads.gravity_m_s2))
        fields["node_pore_pressure_pa"] = ru_pore_pressure_pa(study, node_xy_m, material_at, g)
    return fields


