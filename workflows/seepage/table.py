"""``[seepage]``: the boundary conditions of steady groundwater flow and how the flow is solved.

Each ``[[seepage.boundary]]`` entry applies one condition to the particles on the domain's
boundary (the first mesh's) inside its box, as ``[[boundary]]`` selects supports; entries apply in
file order, a later one over an earlier one.  A boundary particle no entry selects is no-flow,
except below ponded water (``[water] pond_level_m`` between ``pond_x_min_m`` and ``pond_x_max_m``),
where the total head is the pond's level.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from workflows.box import Box
from workflows.fields import Record, StudyError, integer, name_field, number, tables, text

CONDITIONS = ("total_head", "pressure_head", "seepage_face", "inflow", "infiltration", "no_flow")
NEEDS = {"total_head": "total_head_m", "inflow": "flux_m_s", "infiltration": "flux_m_s"}
"""The field each condition needs (``pressure_head`` takes pressure_head_m, default 0)."""

MAX_GRADIENT = 10.0
"""The largest hydraulic gradient a flux may need where it crosses the boundary: ten times the
critical gradient of soil (its buoyant unit weight over the water's, about 1), at which water
leaving the ground lifts it (a quick condition) and rain heavier than the ground conducts stands
on it instead of entering.  Water crossing the boundary at q needs i >= q / k there (Darcy:
q = k i), k at most the largest saturated permeability of the study's materials."""

ROUND_OFF_SPACINGS = 1000
"""A head change within this many spacings of doubles at the heads is round-off: an iteration
asked to go below it may never stop (a tolerance suggested is at least this far above)."""


def check_flow_materials(materials, table: str) -> None:
    """A study whose ``[table]`` computes the water ([seepage], [transient]): no material carries its own
    phreatic line, and every one has a permeability (StudyError naming the material's field)."""
    for i, material in enumerate(materials):
        if material.phreatic_line_m is not None:
            raise StudyError(f"materials[{i}].phreatic_line_m", f"[{table}] computes the pore pressure: leave "
                             "the line out")
        if material.permeability_m_s is None:
            raise StudyError(f"materials[{i}].permeability_m_s", f"{material.name!r} needs a permeability: the "
                             f"study has [{table}]")


@dataclass(frozen=True, kw_only=True)
class SeepageBoundary(Box):
    """A flow condition on the boundary particles inside a box (closed, tolerance h/1000)."""

    name: str = name_field("name of the condition")
    condition: str = text(
        "`total_head` (h = total_head_m), `pressure_head` (h = y + pressure_head_m; 0: atmospheric), "
        "`seepage_face` (atmospheric where water leaves, no flow where it would enter), `inflow` (flux_m_s "
        "normal to the boundary, positive into the ground), `infiltration` (flux_m_s per horizontal length: "
        "rain), `no_flow`", choices=CONDITIONS,
    )
    total_head_m: float | None = number("m", "*condition = total_head:* the total head h (an elevation)",
                                        default=None)
    pressure_head_m: float | None = number("m", "*condition = pressure_head:* h - y; default 0 (atmospheric)",
                                           default=None)
    flux_m_s: float | None = number("m s-1", "*condition = inflow or infiltration:* the water entering per unit "
                                    "area (negative: leaving); at most 10 times the largest permeability of the "
                                    "materials (a hydraulic gradient of 10 where it crosses)", default=None)

    def check(self):
        for name in ("total_head_m", "pressure_head_m", "flux_m_s"):
            wanted = NEEDS.get(self.condition) == name or (name == "pressure_head_m"
                                                          and self.condition == "pressure_head")
            if getattr(self, name) is not None and not wanted:
                raise StudyError(name, f"does not apply to condition = {self.condition}")
        needed = NEEDS.get(self.condition)
        if needed is not None and getattr(self, needed) is None:
            raise StudyError(needed, f"required by condition = {self.condition}")
        super().check()


@dataclass(frozen=True, kw_only=True)
class Seepage(Record):
    """Steady groundwater flow: the pore pressures come from the flow's boundary conditions and each
    material's permeability_m_s (docs/method.md, section 15)."""

    boundary: tuple = tables(SeepageBoundary, "the flow's boundary conditions by position, in order (a "
                             "boundary particle none selects is no-flow, or below ponded water at the pond's "
                             "level)")
    residual_permeability: float = number(
        "1", "k_r0: above the water table the soil conducts this fraction of its permeability (unconfined flow)",
        default=1e-3, gt=0.0, lt=1.0,
    )
    unsaturated_band_m: float = number(
        "m", "k_r falls linearly from 1 at the water table to residual_permeability this far above it (pressure "
        "head); 0: a sharp free surface. Give about 1 m for infiltration through dry ground", default=0.0, ge=0.0,
    )
    tolerance: float = number("1", "the iteration stops once no head changes by more than this times the range "
                              "of the fixed heads (one below the spacing of doubles at the heads is refused)",
                              default=1e-6, gt=0.0, lt=1e-2)
    max_iterations: int = integer("most iterations of the free surface and seepage faces", default=2000, ge=1,
                                  le=20_000)

    def check_in_study(self, study) -> None:
        """[seepage] computes the water: no line or ru beside it, a permeability for every material; then
        the fluxes and the tolerance (:meth:`_check_fluxes_and_tolerance`), their fields under ``seepage.``."""
        water = study.water
        for name in ("phreatic_line_m", "phreatic_level_m", "ru"):
            if water is not None and getattr(water, name) is not None:
                raise StudyError(f"water.{name}", "[seepage] computes the pore pressure: leave the line and ru out")
        check_flow_materials(study.materials, "seepage")
        try:
            largest_permeability = max(m.permeability_m_s * max(1.0, m.permeability_ratio) for m in study.materials)
            self._check_fluxes_and_tolerance(study.geometry.polygon_m, None if water is None else water.pond_level_m,
                                             largest_permeability)
        except StudyError as error:
            raise StudyError(f"seepage.{error.field}", error.problem) from None

    def _check_fluxes_and_tolerance(self, polygon_m, pond_level_m: float | None,
                                    largest_permeability_m_s: float) -> None:
        """StudyError on a flux that needs a hydraulic gradient above ``MAX_GRADIENT`` where it crosses
        the boundary; on ``tolerance`` when it asks for head changes below the spacing of doubles at
        the section's heads, eps max|h| (the heads at least the elevations and the fixed heads the
        study gives; the changes relative to their range): no iteration could stop there."""
        limit_m_s = MAX_GRADIENT * largest_permeability_m_s
        for i, entry in enumerate(self.boundary):
            if entry.flux_m_s is not None and abs(entry.flux_m_s) > limit_m_s:
                raise StudyError(f"boundary[{i}].flux_m_s", (
                    f"{entry.flux_m_s:g} m/s would need a hydraulic gradient of at least "
                    f"{abs(entry.flux_m_s) / largest_permeability_m_s:.3g} where it crosses the boundary (Darcy "
                    f"q = k i, k at most {largest_permeability_m_s:g} m/s in this study): above {MAX_GRADIENT:g}, "
                    f"ten times the critical gradient of soil, no ground carries it; give at most {limit_m_s:.3g} m/s"))
        ys = [y for _, y in polygon_m]
        heads = [*ys, *(h for h in (pond_level_m, *(b.total_head_m for b in self.boundary)) if h is not None)]
        largest_m = max(abs(h) for h in heads) + max([abs(b.pressure_head_m or 0.0) for b in self.boundary],
                                                     default=0.0)
        scale_m = max(max(heads) - min(heads), 1e-12)
        floor = sys.float_info.epsilon * largest_m / scale_m
        if self.tolerance < floor:
            suggested = 10.0 ** math.ceil(math.log10(ROUND_OFF_SPACINGS * floor))
            raise StudyError("tolerance", f"{self.tolerance:g} asks for head changes below "
                             f"{self.tolerance * scale_m:.2g} m, finer than double precision resolves heads of "
                             f"{largest_m:.3g} m "
                             f"({math.ulp(largest_m):.2g} m): the iteration could never stop; give at least "
                             f"{suggested:g} (the default is 1e-6)")
