"""The whole :class:`Study`: its tables, and the checks that span several of them.

Each table is declared in the room of its subject: the study's own in this package (``geometry``,
``supports``, ``solver``, ``records``, ``sweep``), the kinds' in their rooms through their registries:
material models (``workflows.materials``, ``[[materials]]`` by ``model``), stage kinds
(``workflows.stages``, ``[[stages]]`` by ``kind``), loads (``workflows.loads``, ``[loads]``) and
water (``workflows.water.table``, ``[water]``).  A new kind is a module there, not an edit here.
"""

from __future__ import annotations

import dataclasses
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
from workflows.transient.table import Transient
from workflows.water.table import Water, check_water_in_study


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
    transient: Transient | None = optional_table(Transient)
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
        check_water_in_study(self)
        self.loads.check_in_study(self)
        self.output.check_in_study(self)
        if self.metrics is not None:
            self.metrics.check_in_study(self)
        if self.geometry.refined and (self.metrics is not None or any(s.follows_runout for s in self.stages)):
            raise StudyError("geometry.refined", "refined zones apply to gravity and strength-reduction studies; "
                             "runout and collapse metrics assume one spacing (not yet)")
        if self.random_field is not None:
            self.random_field.check_in_study(self)
        if self.probabilistic is not None:
            self.probabilistic.check_in_study(self)
        if self.refinement is not None:
            self.refinement.check_in_study(self)
        if self.transient is not None:
            self.transient.check_in_study(self)
        for i, monitor in enumerate(self.monitors):
            if not points_in_polygon([(monitor.x_m, monitor.y_m)], self.geometry.polygon_m)[0]:
                raise StudyError(
                    f"monitors[{i}]", f"point ({monitor.x_m:g}, {monitor.y_m:g}) lies outside geometry.polygon_m"
                )
