"""``[water]``: ground water, drained and steady, and what it does to the scene.

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

from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import surface_height_m
from workflows.fields import Record, StudyError, number, polyline

OVERBURDEN_SAMPLES = 64
"""Points per particle along the vertical to the surface when integrating the overburden (ru)."""

LEVEL_SPAN_M = 1e9
"""A horizontal piezometric level is the line from -LEVEL_SPAN_M to +LEVEL_SPAN_M: it spans any domain."""


@dataclass(frozen=True, kw_only=True)
class Water(Record):
    """Ground water, drained and steady: a piezometric line (or ru) sets the pore pressure in the ground,
    ponded water loads its surface.  The line is fixed in space while the ground deforms."""

    unit_weight_n_m3: float = number("N m-3", "unit weight gamma_w of water", default=9810.0, gt=0.0)
    phreatic_line_m: tuple | None = polyline(
        "m", "piezometric line [[x, y], ...], x increasing, spanning the domain: u = gamma_w (y_line - y) below "
        "it, 0 above; give phreatic_line_m, phreatic_level_m or ru", default=None,
    )
    phreatic_level_m: float | None = number(
        "m", "a horizontal piezometric line at this height, instead of phreatic_line_m", default=None,
    )
    ru: float | None = number(
        "1", "pore pressure ratio: u = ru sigma_v0, the vertical total stress of the overburden at the "
        "particle's initial position (carried by the particle)", default=None, ge=0.0, lt=1.0,
    )
    pond_level_m: float | None = number(
        "m", "level of water standing on the ground surface: the submerged surface carries gamma_w (level - y) "
        "normal to it, on the current boundary; default: none", default=None,
    )
    pond_x_min_m: float | None = number("m", "the pond stands on the surface from this x (a reservoir against one "
                                        "face); default: unbounded", default=None)
    pond_x_max_m: float | None = number("m", "the pond stands on the surface up to this x; default: unbounded",
                                        default=None)

    def check(self):
        given = [name for name in ("phreatic_line_m", "phreatic_level_m", "ru") if getattr(self, name) is not None]
        if len(given) > 1:
            raise StudyError(given[1], f"give one of phreatic_line_m, phreatic_level_m and ru, not {given[0]} too")
        for name in ("pond_x_min_m", "pond_x_max_m"):
            if getattr(self, name) is not None and self.pond_level_m is None:
                raise StudyError(name, "applies to ponded water: give pond_level_m")
        if self.pond_x_min_m is not None and self.pond_x_max_m is not None and self.pond_x_min_m >= self.pond_x_max_m:
            raise StudyError("pond_x_max_m", f"must be above pond_x_min_m = {self.pond_x_min_m:g}")

    @property
    def pond_x_range_m(self) -> tuple[float, float]:
        """(x_min, x_max) of the ponded water, infinite where unbounded."""
        return (-np.inf if self.pond_x_min_m is None else self.pond_x_min_m,
                np.inf if self.pond_x_max_m is None else self.pond_x_max_m)

    @property
    def phreatic_line(self) -> tuple | None:
        """The piezometric line as points, or None (a level spans any domain: :data:`LEVEL_SPAN_M`)."""
        if self.phreatic_level_m is not None:
            return level_line(self.phreatic_level_m)
        return self.phreatic_line_m


def level_line(level_m: float) -> tuple:
    """The horizontal piezometric line at ``level_m``."""
    return ((-LEVEL_SPAN_M, level_m), (LEVEL_SPAN_M, level_m))


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
    has unless it changes the water."""
    lines, node_line = phreatic_lines(study, node_material)
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


def seepage_fields(study, node_xy_m: np.ndarray, node_material: np.ndarray) -> dict:
    """Scene fields of a study with ``[seepage]``: the flow's pore pressure carried by each particle and,
    where a material has a saturated density, that density at or below the water table."""
    from workflows.seepage.flow import study_flow  # scipy's solver: only with [seepage]

    flow = study_flow(study)
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


def scene_fields(study, node_xy_m: np.ndarray, node_material: np.ndarray, material_at) -> dict:
    """Keyword arguments of ``spfem_core.scene.Scene`` for the study's water (empty without ``[water]``,
    ``[seepage]`` and a material's own piezometric line); saturated densities as a per-particle density."""
    if study.seepage is not None:
        return seepage_fields(study, node_xy_m, node_material)
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


def draw_water(ax, study, x_m: np.ndarray, ground_m: np.ndarray) -> None:
    """The piezometric lines (dashed, below the ground), or the phreatic surface of the study's steady
    seepage, and ponded water (solid) in blue over a figure of the domain, on the abscissae ``x_m``
    where the ground is at ``ground_m``."""
    water = study.water
    if study.seepage is not None:
        from spfem_core.seepage import phreatic_segments
        from workflows.seepage.flow import study_flow

        flow = study_flow(study)
        psi = flow.solution.pressure_head_m(flow.node_xy_m)
        for segment in phreatic_segments(flow.node_xy_m, flow.elem_nodes, psi):
            ax.plot(segment[:, 0], segment[:, 1], "--", color="tab:blue", lw=1.2)
    lines = [] if water is None or water.phreatic_line is None else [water.phreatic_line]
    lines += [m.phreatic_line_m for m in study.materials if m.phreatic_line_m is not None]
    for line in map(np.array, lines):
        ax.plot(x_m, np.minimum(np.interp(x_m, line[:, 0], line[:, 1]), ground_m), "--", color="tab:blue", lw=1.2)
    if water is not None and water.pond_level_m is not None:
        x_min, x_max = water.pond_x_range_m
        wet = (ground_m < water.pond_level_m) & (x_m >= x_min) & (x_m <= x_max)
        ax.plot(x_m, np.where(wet, water.pond_level_m, np.nan), "-", color="tab:blue", lw=1.5)


SURFACE_SAMPLES = 512
"""Abscissae across the domain at which a piezometric line is compared with the ground surface."""


def water_above_ground_warnings(study) -> list[str]:
    """A warning per piezometric line that stands more than one particle spacing above the ground
    surface y_s(x) where no pond covers it: the surface there would carry a pore pressure
    gamma_w (y_w - y_s) that no water above holds, a tensile effective stress (ponded water is
    ``pond_level_m``)."""
    polygon = np.array(study.geometry.polygon_m)
    x = np.linspace(polygon[:, 0].min(), polygon[:, 0].max(), SURFACE_SAMPLES)
    ground_m = surface_height_m(polygon, x)
    water = study.water
    ponded = np.zeros(x.size, dtype=bool)
    if water is not None and water.pond_level_m is not None:
        low, high = water.pond_x_range_m
        ponded = (x >= low) & (x <= high) & (ground_m <= water.pond_level_m)
    named = []
    if water is not None and water.phreatic_line is not None:
        field = "phreatic_level_m" if water.phreatic_level_m is not None else "phreatic_line_m"
        named.append((f"water.{field}", np.array(water.phreatic_line), water.pond_level_m))
    named += [(f"materials[{i}].phreatic_line_m", np.array(m.phreatic_line_m), None)
              for i, m in enumerate(study.materials) if m.phreatic_line_m is not None]
    warnings = []
    for field, line, pond_m in named:
        level_m = np.interp(x, line[:, 0], line[:, 1])
        held = ponded & (level_m <= (np.inf if pond_m is None else pond_m))
        excess_m = np.where(held, -np.inf, np.nan_to_num(level_m - ground_m, nan=-np.inf))
        k = int(np.argmax(excess_m))
        if excess_m[k] > study.geometry.spacing_m:
            warnings.append(
                f"warning: {field}: the water stands {excess_m[k]:.3g} m above the ground surface at x = {x[k]:.4g} m "
                "with no pond there: the ground there carries a pore pressure no water above it holds (its effective "
                "stress turns tensile); "
                "give water.pond_level_m for water standing on the ground, or draw the line at or below it")
    return warnings
