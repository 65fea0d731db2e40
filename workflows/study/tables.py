"""The whole :class:`Study`: its tables, and the checks that span several of them.

Each table is declared in the room of its subject: the study's own in this package (``geometry``,
``supports``, ``solver``, ``records``, ``sweep``), the kinds' in their rooms through their registries:
material models (``workflows.materials``, ``[[materials]]`` by ``model``), stage kinds
(``workflows.stages``, ``[[stages]]`` by ``kind``), loads (``workflows.loads``, ``[loads]``) and
water (``workflows.water.table``, ``[water]``).  A new kind is a module there, not an edit here.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from spfem_core.geometry import points_in_polygon, relief_m
from workflows.fields import Record, StudyError, name_field, optional_table, table, tables, text
from workflows.loads import Loads
from workflows.materials import MATERIAL_MODELS
from workflows.probabilistic.table import Probabilistic
from workflows.random_field.table import RandomField
from workflows.refinement.table import Refinement
from workflows.seepage.table import Seepage
from workflows.stages import STAGE_KINDS
from workflows.stages.strength_reduction import StrengthReductionStage
from workflows.study.geometry import Geometry
from workflows.study.records import Metrics, Monitor, Output
from workflows.study.solver import Solver
from workflows.study.supports import Boundary, Wall
from workflows.study.sweep import Sweep
from workflows.water.table import Water


@dataclass(frozen=True, kw_only=True)
class StudyInfo(Record):
    """What the study is: its name (the default output folder) and a description."""

    name: str = name_field("name of the study; the default output folder is `./<name>`")
    description: str = text("free text: what the study reproduces and why", default="")


@dataclass(frozen=True, kw_only=True)
class Study(Record):
    """A whole study file."""

    study: StudyInfo = table(StudyInfo)
    geometry: Geometry = table(Geometry)
    materials: tuple = tables(
        MATERIAL_MODELS, "materials; a particle takes the last material whose region holds it",
        key="model", key_doc="constitutive model", min_items=1,
    )
    loads: Loads = table(Loads, required=False)
    water: Water | None = optional_table(Water)
    boundary: tuple = tables(Boundary, "prescribed velocities (supports), applied in order")
    walls: tuple = tables(Wall, "rigid walls (segments with friction); none: no contact work at all")
    solver: Solver = table(Solver, required=False)
    stages: tuple = tables(
        STAGE_KINDS, "what to run, in order; each stage continues from the state the previous one left",
        key="kind", key_doc="what the stage does", min_items=1,
    )
    monitors: tuple = tables(Monitor, "points recorded during every stage")
    metrics: Metrics | None = optional_table(Metrics)
    output: Output = table(Output, required=False)
    sweep: Sweep | None = optional_table(Sweep)
    refinement: Refinement | None = optional_table(Refinement)
    probabilistic: Probabilistic | None = optional_table(Probabilistic)
    random_field: RandomField | None = optional_table(RandomField)
    seepage: Seepage | None = optional_table(Seepage)
    source_text: str = dataclasses.field(default="", repr=False, compare=False)
    """The TOML text the study was read from (stored with every result)."""

    @property
    def name(self) -> str:
        return self.study.name

    @property
    def strength_reduction(self) -> StrengthReductionStage | None:
        """The strength-reduction stage (always the last), or None for a plain study."""
        last = self.stages[-1]
        return last if isinstance(last, StrengthReductionStage) else None

    @property
    def slope_height_m(self) -> float:
        """H, the scale of failure: ``strength_reduction.slope_height_m`` if given, else the relief of
        the free surface, the highest minus the lowest point of the polygon's upper boundary (the
        foundation below the toe does not count; ``spfem_core.geometry.relief_m``)."""
        stage = self.strength_reduction
        if stage is not None and stage.slope_height_m is not None:
            return stage.slope_height_m
        return relief_m(self.geometry.polygon_m)

    def check(self):
        for i, stage in enumerate(self.stages):
            stage.check_in_study(self, i)
        known = {b.name for b in self.boundary}
        for i, stage in enumerate(self.stages):
            for name in stage.boundary or ():
                if name not in known:
                    raise StudyError(f"stages[{i}].boundary", f"no [[boundary]] named {name!r} (known: {sorted(known)})")
            if not self.walls and not [b for b in self.boundary if stage.boundary is None or b.name in stage.boundary]:
                field = f"stages[{i}].boundary" if stage.boundary is not None else "boundary"
                raise StudyError(field, f"stage {stage.name!r} has no support and no wall: the body would fall as a "
                                 "whole; give a [[boundary]] (a fixed base, vx_m_s = vy_m_s = 0) and name it here")
        self._check_water_and_loads()
        self.output.check_in_study(self)
        if self.metrics is not None:
            self.metrics.check_in_study(self)
        if self.geometry.refined and (self.metrics is not None or any(s.kind == "runout" for s in self.stages)):
            raise StudyError("geometry.refined", "refined zones apply to gravity and strength-reduction studies; "
                             "runout and collapse metrics assume one spacing (not yet)")
        if self.random_field is not None:
            self.random_field.check_in_study(self)
        if self.probabilistic is not None:
            self.probabilistic.check_in_study(self)
        if self.refinement is not None:
            self.refinement.check_in_study(self)
        for i, monitor in enumerate(self.monitors):
            if not points_in_polygon([(monitor.x_m, monitor.y_m)], self.geometry.polygon_m)[0]:
                raise StudyError(
                    f"monitors[{i}]", f"point ({monitor.x_m:g}, {monitor.y_m:g}) lies outside geometry.polygon_m"
                )

    def _check_water_and_loads(self):
        xs = [x for x, _ in self.geometry.polygon_m]
        x_min, x_max = min(xs), max(xs)
        water = self.water
        lines = [("water.phreatic_line_m", water.phreatic_line_m if water is not None else None)]
        lines += [(f"materials[{i}].phreatic_line_m", m.phreatic_line_m) for i, m in enumerate(self.materials)]
        for field, line in lines:
            if line is not None and (line[0][0] > x_min or line[-1][0] < x_max):
                raise StudyError(field, f"must span the domain's x-range [{x_min:g}, {x_max:g}] m; "
                                 f"it covers [{line[0][0]:g}, {line[-1][0]:g}]")
        study_line = water is not None and water.phreatic_line is not None
        if self.seepage is not None:
            self._check_seepage()
        elif water is not None and not study_line and water.ru is None and water.pond_level_m is None:
            raise StudyError("water.phreatic_line_m", "give phreatic_line_m, phreatic_level_m, ru or pond_level_m "
                             "(or [seepage] to compute the water)")
        for i, material in enumerate(self.materials):
            if self.seepage is not None:
                continue
            if material.saturated_density_kg_m3 is not None and not study_line and material.phreatic_line_m is None:
                raise StudyError(f"materials[{i}].saturated_density_kg_m3", "applies below a piezometric line: give "
                                 "[water] phreatic_line_m or phreatic_level_m, or the material's phreatic_line_m")
            if material.phreatic_line_m is not None and water is not None and water.ru is not None:
                raise StudyError(f"materials[{i}].phreatic_line_m", "give a piezometric line or [water] ru, not both")
        g = math.hypot(*self.loads.gravity_m_s2)
        gamma_w = water.unit_weight_n_m3 if water is not None else 9810.0
        if (water is not None or self.seepage is not None) and g > 0.0:
            for i, material in enumerate(self.materials):
                wet = material.saturated_density_kg_m3 or material.density_kg_m3
                field = "saturated_density_kg_m3" if material.saturated_density_kg_m3 else "density_kg_m3"
                if wet * g <= gamma_w:
                    raise StudyError(f"materials[{i}].{field}", f"{wet:g} kg/m3 is a saturated unit weight of "
                                     f"{wet * g / 1e3:.3g} kN/m3, no more than the water's ({gamma_w / 1e3:.3g} "
                                     "kN/m3): the soil would float (negative buoyant weight); saturated soils are "
                                     "1,600-2,300 kg/m3")
        for where, load in self.loads.surface_loads():
            for field, x in load.abscissae_m().items():
                if not x_min <= x <= x_max:
                    raise StudyError(f"{where}.{field}", f"{x:g} m is off the ground surface, which spans "
                                     f"x = {x_min:g} to {x_max:g} m")
        first = self.stages[0]
        ramp = self.loads.ramp_time_s
        if ramp is not None and ramp > first.time_limit_s:
            raise StudyError("loads.ramp_time_s", f"must be <= the first stage's {first.duration_field} = "
                             f"{first.time_limit_s:g}, got {ramp:g}")
        seismic = self.loads.seismic
        if seismic is not None and not seismic.in_gravity and self.strength_reduction is None:
            raise StudyError("loads.seismic.in_gravity", "false applies the load in strength-reduction runs only, "
                             "and this study has none")

    def _check_seepage(self):
        """[seepage] computes the water: no line or ru beside it, a permeability for every material."""
        water = self.water
        for name in ("phreatic_line_m", "phreatic_level_m", "ru"):
            if water is not None and getattr(water, name) is not None:
                raise StudyError(f"water.{name}", "[seepage] computes the pore pressure: leave the line and ru out")
        for i, material in enumerate(self.materials):
            if material.phreatic_line_m is not None:
                raise StudyError(f"materials[{i}].phreatic_line_m", "[seepage] computes the pore pressure: leave "
                                 "the line out")
            if material.permeability_m_s is None:
                raise StudyError(f"materials[{i}].permeability_m_s", f"{material.name!r} needs a permeability: "
                                 "the study has [seepage]")
        try:
            largest_permeability = max(m.permeability_m_s * max(1.0, m.permeability_ratio) for m in self.materials)
            self.seepage.check_in_study(self.geometry.polygon_m, None if water is None else water.pond_level_m,
                                        largest_permeability)
        except StudyError as error:
            raise StudyError(f"seepage.{error.field}", error.problem) from None
