"""``[water]``: ground water, drained and steady, as the study file declares it.

A piezometric line (the study's, or a material's own perched line) or ``ru`` sets the pore pressure
in the ground, a material's saturated density its weight at or below its line, and ponded water
at ``pond_level_m`` loads the ground's surface between ``pond_x_min_m`` and ``pond_x_max_m``;
``[seepage]`` (``workflows.seepage``) computes the water instead of a line.  What the water does
to the particles is ``workflows.water.pressure``; :func:`water_above_ground_warnings` names a line
drawn above the ground before a study runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import surface_height_m
from workflows.fields import Record, StudyError, number, polyline

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


def check_water_in_study(study) -> None:
    """StudyError on the study's water: a piezometric line (the study's or a material's) that does not
    span the domain; [seepage] beside a line or ru, or a material without a permeability beside it
    (``workflows.seepage.table.Seepage.check_in_study``); [water] that sets no water; a saturated
    density with no line to be below, a material's line beside ru; a soil that would float."""
    xs = [x for x, _ in study.geometry.polygon_m]
    x_min, x_max = min(xs), max(xs)
    water = study.water
    lines = [("water.phreatic_line_m", water.phreatic_line_m if water is not None else None)]
    lines += [(f"materials[{i}].phreatic_line_m", m.phreatic_line_m) for i, m in enumerate(study.materials)]
    for field, line in lines:
        if line is not None and (line[0][0] > x_min or line[-1][0] < x_max):
            raise StudyError(field, f"must span the domain's x-range [{x_min:g}, {x_max:g}] m; "
                             f"it covers [{line[0][0]:g}, {line[-1][0]:g}]")
    study_line = water is not None and water.phreatic_line is not None
    computed = study.seepage is not None or study.transient is not None  # a flow computes the water
    if study.seepage is not None:
        study.seepage.check_in_study(study)
    elif water is not None and not computed and not study_line and water.ru is None and water.pond_level_m is None:
        raise StudyError("water.phreatic_line_m", "give phreatic_line_m, phreatic_level_m, ru or pond_level_m "
                         "(or [seepage] to compute the water)")
    for i, material in enumerate(study.materials):
        if computed:
            continue
        if material.saturated_density_kg_m3 is not None and not study_line and material.phreatic_line_m is None:
            raise StudyError(f"materials[{i}].saturated_density_kg_m3", "applies below a piezometric line: give "
                             "[water] phreatic_line_m or phreatic_level_m, or the material's phreatic_line_m")
        if material.phreatic_line_m is not None and water is not None and water.ru is not None:
            raise StudyError(f"materials[{i}].phreatic_line_m", "give a piezometric line or [water] ru, not both")
    g = math.hypot(*study.loads.gravity_m_s2)
    gamma_w = water.unit_weight_n_m3 if water is not None else 9810.0
    if (water is not None or computed) and g > 0.0:
        for i, material in enumerate(study.materials):
            wet = material.saturated_density_kg_m3 or material.density_kg_m3
            field = "saturated_density_kg_m3" if material.saturated_density_kg_m3 else "density_kg_m3"
            if wet * g <= gamma_w:
                raise StudyError(f"materials[{i}].{field}", f"{wet:g} kg/m3 is a saturated unit weight of "
                                 f"{wet * g / 1e3:.3g} kN/m3, no more than the water's ({gamma_w / 1e3:.3g} "
                                 "kN/m3): the soil would float (negative buoyant weight); saturated soils are "
                                 "1,600-2,300 kg/m3")


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
