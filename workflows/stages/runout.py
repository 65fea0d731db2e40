"""``kind = "runout"``: a failure followed to rest, and what it did.

Explicit dynamics with the strength divided by ``strength_factor`` from the previous stage's
stresses, until the flow is at rest (``workflows.runout.rest``) or ``max_duration_s``.  A trigger
may start it: a horizontal seismic coefficient out of the slope, a new piezometric level or
ponded water from the start of the stage.  The result file carries the runout metrics
(``workflows.runout.metrics``: runout, retrogression, sliding mass, speeds, energy budget, final
surface), and a figure shows the final state over the initial outline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from spfem_core.geometry import downslope_sign
from workflows.fields import StudyError, number
from workflows.loads.seismic import OUT_OF_SLOPE, horizontal_sign, with_horizontal
from workflows.output.variables import RUNOUT_METRICS
from workflows.runout.figures import runout_fields
from workflows.runout.rest import rest_rule
from workflows.stages.base import StageBase
from workflows.water.table import level_line

DEFAULT_REST_KINETIC_FRACTION = 1e-3
DEFAULT_RUNOUT_REST_WINDOW_S = 0.5
DEFAULT_DEPOSIT_THICKNESS = 0.02
"""Default deposit thickness, as a fraction of the slope height."""
DEFAULT_MOVED_FRACTION = 0.01
"""Default moved threshold, as a fraction of the slope height."""


@dataclass(frozen=True, kw_only=True)
class RunoutStage(StageBase):
    """Runout after failure: explicit dynamics with the strength divided by a factor, from the previous
    stage's stresses, until the flow is at rest or max_duration_s; the result file carries the runout
    metrics (runout, retrogression, sliding mass, speeds, energy budget, final surface)."""

    kind: ClassVar[str] = "runout"
    duration_field: ClassVar[str] = "max_duration_s"
    animated: ClassVar[bool] = True
    follows_runout: ClassVar[bool] = True
    max_duration_s: float = number("s", "stop here if the flow has not come to rest", gt=0.0)
    strength_factor: float = number(
        "1", "the strength at the start of the stage is c / F and tan(phi) / F (dilation min(psi, phi_F)); "
        "1: as declared (with softening, the flow comes from it)", default=1.0, gt=0.0,
    )
    damping: float = number("1", "local (Cundall) damping factor; 0 is undamped dynamics", default=0.0, ge=0.0,
                            lt=1.0)
    rest_fraction: float = number(
        "1", "at rest: kinetic energy below this fraction of the potential energy released so far, sustained over "
        "rest_window_s", default=DEFAULT_REST_KINETIC_FRACTION, gt=0.0, lt=1.0,
    )
    rest_window_s: float = number("s", "see rest_fraction", default=DEFAULT_RUNOUT_REST_WINDOW_S, gt=0.0)
    deposit_thickness_m: float | None = number(
        "m", "the surface counts as raised (runout) or lowered (retrogression) where it moved more than this from "
        f"the initial surface; default {DEFAULT_DEPOSIT_THICKNESS:.0%} of the slope height", default=None, gt=0.0,
    )
    moved_threshold_m: float | None = number(
        "m", "a particle that moved more than this belongs to the sliding mass; default "
        f"{DEFAULT_MOVED_FRACTION:.0%} of the slope height", default=None, gt=0.0,
    )
    horizontal_coefficient: float | None = number(
        "1", "trigger: a horizontal seismic coefficient kh acting out of the slope from the start of this stage "
        "(instead of [loads.seismic]); default: the study's loads", default=None, ge=0.0, lt=1.0,
    )
    phreatic_level_m: float | None = number(
        "m", "trigger: a horizontal piezometric line at this height from the start of this stage (a water-level "
        "change; materials with their own line keep it); default: the study's [water]", default=None,
    )
    pond_level_m: float | None = number(
        "m", "trigger: ponded water at this level from the start of this stage; default: the study's [water]",
        default=None,
    )

    def check(self):
        super().check()
        if self.elastic:
            raise StudyError("elastic", "must be false: a runout stage needs a plastic material")

    def materials(self, table):
        """The declared strength divided by ``strength_factor`` (c / F, tan(phi) / F)."""
        table = super().materials(table)
        return table if self.strength_factor == 1.0 else table.with_strength_reduction(self.strength_factor)

    def acceleration_m_s2(self, study) -> np.ndarray:
        """The study's, or gravity with the stage's own ``horizontal_coefficient`` out of the slope."""
        if self.horizontal_coefficient is None:
            return super().acceleration_m_s2(study)
        polygon = study.geometry.polygon_m
        return with_horizontal(study.loads.gravity_m_s2, self.horizontal_coefficient,
                               horizontal_sign(OUT_OF_SLOPE, polygon))

    def water(self, study_water: tuple, study, node_material: np.ndarray) -> tuple:
        """The study's water, or the stage's own piezometric level (for the materials without a line of
        their own) and ponded water."""
        lines, node_line, pond = study_water
        if self.phreatic_level_m is not None:
            lines = lines + (np.array(level_line(self.phreatic_level_m)),)
            own = np.array([m.phreatic_line_m is not None for m in study.materials])[node_material]
            node_line = np.where(own, node_line, len(lines) - 1)
        if self.pond_level_m is not None:
            pond = self.pond_level_m
        return lines, node_line, pond

    def run(self, sim, monitor_nodes, *, progress=None, snapshot=None, next_starts_over=False):
        """Explicit dynamics until the flow is at rest (``runout.rest.rest_rule``) or ``max_duration_s``."""
        return sim.run(self.max_duration_s, damping=self.damping, record_interval_s=self.record_interval_s,
                       monitor_nodes=monitor_nodes, progress=progress, snapshot=snapshot,
                       stop=rest_rule(self.rest_fraction, self.rest_window_s))

    def add_results(self, dataset, study, series, final) -> None:
        """The runout metrics of ``workflows.runout.metrics`` (on the particles in the final mesh)."""
        # imported here: the metrics need scipy, which the study reader must not import
        from workflows.runout.metrics import final_surface, runout_summary, surface_change

        meshed = final.meshed
        height = study.slope_height_m
        summary = runout_summary(
            study.geometry.polygon_m, final.xy_m[meshed], final.displacement_m, final.initial_area_m2,
            final.spacing_m, series.time_s, series.energy_j_per_m, series.max_speed_m_s,
            deposit_thickness_m=self.deposit_thickness_m or DEFAULT_DEPOSIT_THICKNESS * height,
            moved_threshold_m=self.moved_threshold_m or DEFAULT_MOVED_FRACTION * height,
            rest_fraction=self.rest_fraction, rest_window_s=self.rest_window_s,
        )
        for key, value in summary.items():
            dataset[key] = RUNOUT_METRICS[key](value)
        problems = []
        if math.isnan(summary["time_to_rest_s"]) and summary["sliding_mass_area_m2"] > 0.0:  # (a slope that did
            # not slide never "rests": its kinetic energy is not below a share of a release it never made)
            problems.append(f"the flow was still moving at max_duration_s = {self.max_duration_s:g} s (time_to_rest_s "
                            "is NaN): the runout and deposit are where it had got to, not final; give a longer "
                            "max_duration_s")
        polygon = study.geometry.polygon_m
        sign = downslope_sign(polygon) or -1.0
        edge = max(sign * x for x, _ in polygon)  # along the slide
        _, _, toe, _ = surface_change(polygon, np.zeros(0), np.zeros(0), sign)
        if summary["runout_m"] >= edge - toe - 2.0 * final.spacing_m:
            problems.append(f"the deposit reached the end of the domain at x = {sign * edge:g} m: runout_m is a "
                            "lower bound; extend the domain downslope")
        dataset.attrs["final"] = int(not problems)
        dataset.attrs["warning"] = "; ".join(problems)
        x_m, height_m = final_surface(final.xy_m[meshed], final.spacing_m)
        dataset["surface_x"] = RUNOUT_METRICS["surface_x"](x_m)
        dataset["surface_height"] = RUNOUT_METRICS["surface_height"](height_m)
        dataset.attrs["metrics_kind"] = "runout"

    def figures(self, study, result_path, out_dir) -> list:
        """``<stage>.png``: the final state over the initial outline (``runout.figures``)."""
        if not study.output.figures:
            return []
        return [runout_fields(result_path, Path(out_dir) / f"{self.name}.png", self.strength_factor,
                              study.geometry.polygon_m)]
