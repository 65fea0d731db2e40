"""``[transient]``: water that changes with time (rain, a falling reservoir) through unsaturated soil,
and the factor of safety it leaves.

Each material gets a soil-water curve (``[[transient.curves]]``: van Genuchten with Mualem's
conductivity, or Gardner's exponential model, with its saturated storage); each
``[[transient.boundary]]`` entry applies one condition in time to the particles of the domain's
boundary inside its box (as ``[[boundary]]`` selects supports, a later entry over an earlier one):
rain (a constant intensity or a history, in mm/h, per horizontal length or normal to the surface,
held at atmospheric pressure where the surface ponds) less an evaporation (held at the dry limit
``surface_min_head_m`` where the soil cannot supply it), a reservoir (a level history: its head below
the level, a seepage face above it, and its water on the face), a seepage face, a fixed total or
pressure head.  The flow starts from a water table or from the steady flow of ``[seepage]``.

The stages see the water at one time: ``water_at_h`` (a single study, or each case of a sweep), or
a study of the FOS against time makes a case per time of ``fos_times_h`` or every
``fos_interval_h`` (``workflows.transient.study_type``).  Above the water table the water's suction
holds the grains together: each particle carries the pore pressure u = S_e(psi) gamma_w psi (Bishop's
chi = S_e, the suction stress of Lu & Likos 2006; docs/method.md, section 17), or gamma_w max(psi, 0)
without ``suction_in_strength``.

A history is a list of points [[t_h, value], ...] with times increasing, or the name of a CSV file of
two columns beside the study (``workflows.study.line_files``).  Rain is piecewise constant: the
intensity of a point holds until the next point's time, the last one's to the end (end a storm with
[t, 0]); a reservoir level is linear between its points, constant beyond them.
"""

from __future__ import annotations

from dataclasses import dataclass

from workflows.box import Box
from workflows.fields import Record, StudyError, boolean, integer, name_field, number, numbers, polyline, tables, text
from workflows.seepage.table import check_flow_materials

MODELS = ("van_genuchten", "gardner")
CONDITIONS = ("rain", "reservoir", "seepage_face", "total_head", "pressure_head", "no_flow")
NEEDS = {"total_head": ("total_head_m",), "reservoir": ("level_history_h_m",),
         "rain": ("rain_mm_h", "rain_history_h_mm_h")}
"""The fields each condition takes (rain: one of the two, or evaporation_mm_h alone)."""
ONLY_FOR = {"total_head_m": "total_head", "pressure_head_m": "pressure_head", "level_history_h_m": "reservoir",
            "rain_mm_h": "rain", "rain_history_h_mm_h": "rain", "rain_direction": "rain",
            "evaporation_mm_h": "rain", "surface_min_head_m": "rain", "loading_efficiency": "reservoir"}
SURFACE_MIN_HEAD_M = -1000.0
"""The default dry limit of an evaporating surface: HYDRUS's customary hCritA (1e5 cm); by Kelvin's law
psi = (R T / (M_w g)) ln(RH), the soil water in equilibrium with air of 93% relative humidity at 20 C."""
DEFAULTS = {"rain_direction": "horizontal", "loading_efficiency": 1.0, "surface_min_head_m": SURFACE_MIN_HEAD_M}
"""The fields of ONLY_FOR whose default is not None."""
MM_H_TO_M_S = 1e-3 / 3600.0
"""1 mm/h in m/s."""
HOUR_S = 3600.0
MAX_FOS_TIMES = 200
"""The most FOS searches a study of the FOS against time may ask for."""


@dataclass(frozen=True, kw_only=True)
class SoilWaterCurve(Record):
    """A material's soil-water characteristic curve (docs/method.md, section 17)."""

    material: str = name_field("the material (its `name` in [[materials]]) the curve belongs to")
    model: str = text("`van_genuchten` (with Mualem's conductivity) or `gardner` (exponential: S_e = k_r = "
                      "exp(alpha psi))", choices=MODELS)
    residual_water_content: float = number("1", "theta_r", default=0.0, ge=0.0, lt=1.0)
    saturated_water_content: float = number("1", "theta_s (about the porosity)", gt=0.0, le=1.0)
    alpha_1_m: float = number("m-1", "alpha: van Genuchten's, about the inverse of the air-entry head; "
                              "Gardner's desaturation rate", gt=0.0)
    n: float | None = number("1", "*model = van_genuchten:* n > 1 (m = 1 - 1/n)", default=None, gt=1.0)
    specific_storage_1_m: float = number("m-1", "S_s: the water a saturated soil stores per metre of pressure "
                                         "head and unit volume", default=0.0, ge=0.0, lt=1.0)

    def check(self):
        if self.model == "van_genuchten" and self.n is None:
            raise StudyError("n", "required by model = van_genuchten")
        if self.model == "gardner" and self.n is not None:
            raise StudyError("n", "does not apply to model = gardner")
        if self.residual_water_content >= self.saturated_water_content:
            raise StudyError("residual_water_content", f"must be below saturated_water_content = "
                             f"{self.saturated_water_content:g}")


@dataclass(frozen=True, kw_only=True)
class TransientBoundary(Box):
    """A flow condition in time on the boundary particles inside a box (closed, tolerance h/1000)."""

    name: str = name_field("name of the condition")
    condition: str = text(
        "`rain` (rain_mm_h or rain_history_h_mm_h, less evaporation_mm_h; atmospheric where the surface ponds, "
        "the rest runs off; at surface_min_head_m where it dries), "
        "`reservoir` (level_history_h_m: the reservoir's head below its level, a seepage face above, its water "
        "on the surface), `seepage_face`, `total_head`, `pressure_head` (h = y + pressure_head_m), `no_flow`",
        choices=CONDITIONS)
    rain_mm_h: float | None = number("mm h-1", "*condition = rain:* a constant intensity", default=None, ge=0.0)
    rain_history_h_mm_h: tuple | None = polyline(
        "h, mm h-1", "*condition = rain:* the intensity against time [[t_h, mm_h], ...] (or a CSV file): each "
        "holds until the next time, the last to the end", default=None)
    rain_direction: str = text("*condition = rain:* `horizontal` (the intensity per horizontal length, as a "
                               "rain gauge measures it) or `normal` (per length of the surface)",
                               default="horizontal", choices=("horizontal", "normal"))
    evaporation_mm_h: float | None = number(
        "mm h-1", "*condition = rain:* the evaporation the air demands of the surface (the potential evaporation), "
        "taken from the rain at every time: the surface's flux is the rain less this, upward where the rain is less; "
        "without rain_mm_h or rain_history_h_mm_h, no rain", default=None, gt=0.0)
    surface_min_head_m: float = number(
        "m", "*condition = rain, with evaporation_mm_h:* the driest pressure head the surface reaches: where the soil "
        "cannot supply the evaporation the surface is held at this head and gives what the soil lifts (default: "
        "HYDRUS's customary limit, in equilibrium with air of 93% relative humidity)", default=SURFACE_MIN_HEAD_M,
        lt=0.0)
    level_history_h_m: tuple | None = polyline(
        "h, m", "*condition = reservoir:* the level against time [[t_h, level_m], ...] (or a CSV file), linear "
        "between the points", default=None)
    loading_efficiency: float = number(
        "1", "*condition = reservoir:* the share of a change of the reservoir's water load on the ground that the "
        "pore pressure below takes at once (Skempton's B-bar: 1 for saturated soil unloaded faster than it "
        "drains, the rapid-drawdown assumption; 0: the flow alone changes it)", default=1.0, ge=0.0, le=1.0)
    total_head_m: float | None = number("m", "*condition = total_head:* the total head h", default=None)
    pressure_head_m: float | None = number("m", "*condition = pressure_head:* h - y (default 0: atmospheric)",
                                           default=None)

    def check(self):
        for name, condition in ONLY_FOR.items():
            default = DEFAULTS.get(name)
            if getattr(self, name) != default and self.condition != condition:
                raise StudyError(name, f"does not apply to condition = {self.condition}")
        needed = NEEDS.get(self.condition, ())
        given = [name for name in needed if getattr(self, name) is not None]
        if self.surface_min_head_m != SURFACE_MIN_HEAD_M and self.evaporation_mm_h is None:
            raise StudyError("surface_min_head_m", "applies to an evaporating surface: give evaporation_mm_h")
        if needed and not given and self.evaporation_mm_h is None:
            raise StudyError(needed[0], f"required by condition = {self.condition}"
                             + (f" (or {needed[1]})" if len(needed) > 1 else ""))
        if len(given) > 1:
            raise StudyError(given[1], f"give {given[0]} or {given[1]}, not both")
        history = self.rain_history_h_mm_h
        if history is not None and min(v for _, v in history) < 0.0:
            raise StudyError("rain_history_h_mm_h", "an intensity must be >= 0 (give evaporation as "
                             "evaporation_mm_h)")
        for name in ("rain_history_h_mm_h", "level_history_h_m"):
            points = getattr(self, name)
            if points is not None and points[0][0] < 0.0:
                raise StudyError(name, f"times start at 0 h or later, got {points[0][0]:g}")
        super().check()


@dataclass(frozen=True, kw_only=True)
class Transient(Record):
    """Transient unsaturated flow (rain, drawdown) and the factor of safety against time."""

    curves: tuple = tables(SoilWaterCurve, "a soil-water curve per material", unique="material", min_items=1)
    boundary: tuple = tables(TransientBoundary, "the flow's conditions in time by position, in order (a boundary "
                             "particle none selects is no-flow)")
    end_time_h: float = number("h", "the flow is followed from 0 to this time", gt=0.0, le=1e6)
    initial_state: str = text("`water_table` (hydrostatic below initial_water_table_m, its suction above) or "
                              "`steady` (the steady flow of [seepage])", default="water_table",
                              choices=("water_table", "steady"))
    initial_water_table_m: float | None = number("m", "*initial_state = water_table:* a horizontal water table "
                                                 "at this height", default=None)
    initial_water_line_m: tuple | None = polyline("m", "*initial_state = water_table:* a water table [[x, y], "
                                                  "...] instead", default=None)
    suction_limit_m: float | None = number("m", "the initial suction (above the water table) is at most this "
                                           "pressure head; default: hydrostatic to the surface", default=None, gt=0.0)
    water_at_h: float | None = number("h", "the stages see the water at this time (a single FOS; a sweep may vary "
                                      "it). Leave it out for the FOS against time", default=None, ge=0.0)
    fos_times_h: tuple | None = numbers("h", "the FOS against time: a search at each of these times",
                                        default=None, ge=0.0)
    fos_interval_h: float | None = number("h", "the FOS against time: a search at 0 and every this many hours "
                                          "to end_time_h", default=None, gt=0.0)
    stop_below_fos: float | None = number("1", "the FOS against time stops at the first time its FOS is below "
                                          "this (e.g. 1.0: at failure)", default=None, gt=0.0)
    runout_duration_s: float | None = number(
        "s", "with stop_below_fos: the slope that fails is followed after failure, at the water of the time it "
        "failed, its own strength (a runout stage, strength_factor 1) for at most this long, from its gravity state; "
        "its files in runout/", default=None, gt=0.0)
    suction_in_strength: bool = boolean("the suction above the water table adds to the effective stress "
                                           "(u = S_e gamma_w psi); false: u = gamma_w max(psi, 0)", default=True)
    max_step_h: float = number("h", "the longest time step of the flow", default=1.0, gt=0.0)
    saved_times: int = integer("times written to transient.nc besides those of the FOS (evenly spaced)",
                               default=24, ge=1, le=1000)

    def check(self):
        if self.initial_state == "water_table":
            given = [n for n in ("initial_water_table_m", "initial_water_line_m") if getattr(self, n) is not None]
            if not given:
                raise StudyError("initial_water_table_m", "required by initial_state = water_table (or "
                                 "initial_water_line_m)")
            if len(given) > 1:
                raise StudyError(given[1], f"give {given[0]} or {given[1]}, not both")
        else:
            for name in ("initial_water_table_m", "initial_water_line_m"):
                if getattr(self, name) is not None:
                    raise StudyError(name, "does not apply to initial_state = steady")
        against_time = [n for n in ("fos_times_h", "fos_interval_h") if getattr(self, n) is not None]
        if len(against_time) > 1:
            raise StudyError(against_time[1], f"give {against_time[0]} or {against_time[1]}, not both")
        if self.water_at_h is not None and against_time:
            raise StudyError(against_time[0], "the FOS against time sets the water's time of each case: leave "
                             "water_at_h out")
        for name in ("water_at_h", "fos_interval_h"):
            value = getattr(self, name)
            if value is not None and value > self.end_time_h:
                raise StudyError(name, f"{value:g} h is after end_time_h = {self.end_time_h:g} h")
        if self.fos_times_h is not None:
            if not self.fos_times_h:
                raise StudyError("fos_times_h", "give at least one time")
            if any(b <= a for a, b in zip(self.fos_times_h, self.fos_times_h[1:])):
                raise StudyError("fos_times_h", "the times must increase")
            if self.fos_times_h[-1] > self.end_time_h:
                raise StudyError("fos_times_h", f"{self.fos_times_h[-1]:g} h is after end_time_h = "
                                 f"{self.end_time_h:g} h")
        if len(self.fos_times()) > MAX_FOS_TIMES:
            raise StudyError("fos_interval_h", f"asks for {len(self.fos_times())} FOS searches; at most "
                             f"{MAX_FOS_TIMES}")
        if self.stop_below_fos is not None and not against_time:
            raise StudyError("stop_below_fos", "applies to the FOS against time (fos_times_h or fos_interval_h)")
        if self.runout_duration_s is not None and self.stop_below_fos is None:
            raise StudyError("runout_duration_s", "follows the slope once its FOS falls below stop_below_fos: give "
                             "stop_below_fos")
        reservoirs = [i for i, entry in enumerate(self.boundary) if entry.condition == "reservoir"]
        if len(reservoirs) > 1:
            raise StudyError(f"boundary[{reservoirs[1]}].condition", "one reservoir per study (its water loads the "
                             "surface): give the others as total_head entries")
        if self.max_step_h > self.end_time_h:
            raise StudyError("max_step_h", f"{self.max_step_h:g} h is longer than end_time_h = {self.end_time_h:g} h")

    @property
    def against_time(self) -> bool:
        """Whether the study is the FOS against time (a case per time)."""
        return self.fos_times_h is not None or self.fos_interval_h is not None

    def fos_times(self) -> tuple[float, ...]:
        """The times (h) of the FOS against time: fos_times_h, or 0, interval, ... up to end_time_h."""
        if self.fos_times_h is not None:
            return tuple(self.fos_times_h)
        if self.fos_interval_h is None:
            return ()
        count = int(self.end_time_h / self.fos_interval_h + 1e-9)
        times = [round(k * self.fos_interval_h, 9) for k in range(count + 1)]
        return tuple(times if times[-1] >= self.end_time_h - 1e-9 else [*times, self.end_time_h])

    @property
    def water_time_h(self) -> float:
        """The time of the water the stages see: water_at_h, or the first time of the FOS against time."""
        return self.water_at_h if self.water_at_h is not None else self.fos_times()[0]

    def reservoir_level_m(self, time_h: float | None = None) -> float | None:
        """The reservoir's level at ``time_h`` (default :attr:`water_time_h`): linear between the points of its
        history, constant beyond them; None without a reservoir."""
        entry = next((b for b in self.boundary if b.condition == "reservoir"), None)
        if entry is None:
            return None
        t = self.water_time_h if time_h is None else time_h
        times, levels = [p[0] for p in entry.level_history_h_m], [p[1] for p in entry.level_history_h_m]
        if t <= times[0]:
            return levels[0]
        for k in range(1, len(times)):
            if t <= times[k]:
                return levels[k - 1] + (levels[k] - levels[k - 1]) * (t - times[k - 1]) / (times[k] - times[k - 1])
        return levels[-1]

    def check_in_study(self, study) -> None:
        """[transient] computes the water: no line or ru beside it; every material has a permeability and a
        curve, every curve a material; the initial state's table; no probabilistic study, and no sweep of
        the FOS against time (not yet).  Fields named in full."""
        self._check_in_study(study)

    def _check_in_study(self, study) -> None:
        water = study.water
        for name in ("phreatic_line_m", "phreatic_level_m", "ru"):
            if water is not None and getattr(water, name) is not None:
                raise StudyError(f"water.{name}", "[transient] computes the pore pressure: leave the line and ru out")
        if water is not None and water.pond_level_m is not None:
            raise StudyError("water.pond_level_m", "[transient] gives a reservoir's water as a condition = "
                             "\"reservoir\" entry of [[transient.boundary]]: leave pond_level_m out")
        names = [material.name for material in study.materials]
        check_flow_materials(study.materials, "transient")
        for material in study.materials:
            if material.name not in [curve.material for curve in self.curves]:
                raise StudyError("transient.curves", f"no soil-water curve for the material {material.name!r}")
        for i, curve in enumerate(self.curves):
            if curve.material not in names:
                raise StudyError(f"transient.curves[{i}].material", f"no material named {curve.material!r} (known: {names})")
        if self.initial_state == "steady" and study.seepage is None:
            raise StudyError("transient.initial_state", "steady needs the steady flow's conditions: add [seepage]")
        if self.initial_state == "water_table" and study.seepage is not None:
            raise StudyError("seepage", "applies to initial_state = \"steady\" (the flow the transient starts from); "
                             "leave [seepage] out or set transient.initial_state = \"steady\"")
        if study.probabilistic is not None or study.random_field is not None:
            raise StudyError("probabilistic", "[transient] with a probabilistic study or a random field: not yet")
        if self.against_time:
            if study.sweep is not None:
                raise StudyError("sweep", "a sweep of the FOS against time: not yet; sweep water_at_h instead "
                                 "(a case per time)")
            if study.refinement is not None:
                raise StudyError("refinement", "the FOS against time with [refinement]: not yet")
            if study.strength_reduction is None:
                raise StudyError("stages", "the FOS against time needs a strength_reduction stage (the last)")
        elif self.water_at_h is None:
            raise StudyError("transient.water_at_h", "give the time of the water the stages see (or fos_times_h / "
                             "fos_interval_h for the FOS against time)")
        for i, entry in enumerate(self.boundary):
            for name in ("rain_history_h_mm_h", "level_history_h_m"):
                points = getattr(entry, name)
                if points is not None and points[0][0] > self.end_time_h:
                    raise StudyError(f"transient.boundary[{i}].{name}", f"starts at {points[0][0]:g} h, after "
                                     f"end_time_h = {self.end_time_h:g} h")
