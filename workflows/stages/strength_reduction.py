"""``kind = "strength_reduction"``: the factor of safety, one run per strength reduction factor F.

The last stage of a study: every run starts from the gravity state the stages before left (at
the original positions, at rest) with the strength divided by F as each material's model says
(c / F, tan(phi) / F; psi_F by the flow rule), the seismic load acting, and goes on by its
protocol until the slope is at rest or has slid (``workflows.fos``: the search over F, the verdicts
and the FOS).  Protocols (``workflows.stages.protocols``, each with its run and checks):

- ``quasi_static``: the reduced strength at once, then dynamic relaxation with local damping
  (``damping``) at the largest stable step until the unbalanced-force ratio falls below
  ``tolerance`` (the slope is at rest) or ``duration_s`` (Dawson, Roth & Drescher 1999 in a
  large-deformation setting);
- ``ramp``: undamped dynamics with the strength falling linearly in 1/F from full to c / F over
  ``ramp_time_s`` (in ``protocols.RAMP_STEPS`` steps), then held; F <= 1 (a stronger slope) at once;
- ``sudden``: the reduced strength at once, undamped dynamics.

The scales of a slope (:meth:`StrengthReductionStage.response_time_s`, ``Study.slope_height_m``)
set the defaults: a run has failed once it moved ``FAILURE_FRACTION_OF_HEIGHT`` of the slope
height, and stops once it slid ``SLIDE_STOP_FRACTION`` of it.

**Stiffness of the runs** (:meth:`StrengthReductionStage.stiffness_factor`).  The FOS of a perfectly
plastic slope is a collapse load: it does not depend on the elastic moduli.  The contained
elastic-plastic displacement of a run below the FOS does: it is of the order of the slope's
elastic response u_el = gamma H^2 / (2 G) (the shear displacement of a layer H thick under a
shear stress growing to gamma H), and on a soft soil it passes the failure displacement long
before a mechanism forms; on a stiff one an arrested slide of a few centimetres hides below it.
The runs therefore use every modulus times

    s = max_k (rho_k |g| H / (2 G_k)) / ELASTIC_RESPONSE,

so that the softest material's u_el is ``ELASTIC_RESPONSE`` of H whatever the declared stiffness.
In small-strain theory this changes no stress of the elastic-plastic solution and divides its
displacements by s, while a mechanism's displacement is not divided: every run of a slope is
then the same run whatever its moduli (their ratios kept), and the verdicts separate the
contained response from a slide.  Softening materials, whose strength follows the plastic
strain, keep their moduli (s = 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from workflows.fields import StudyError, boolean, integer, number, text
from workflows.stages.base import ORIGINAL_POSITIONS, StageBase
from workflows.stages.flow_rules import FLOW_RULES, FlowRule
from workflows.stages.protocols import PROTOCOLS, Protocol

OPTIONAL_PROTOCOL_FIELDS = ("damping", "tolerance", "ramp_time_s", "rest_window_s", "rest_growth")
"""The fields that apply to some protocols only (each protocol's ``fields``), checked in this order."""
DEFAULT_QUASI_STATIC_DAMPING = 0.7
DEFAULT_QUASI_STATIC_TOLERANCE = 1e-5
DEFAULT_REST_WINDOW_S = 1.0
DEFAULT_REST_GROWTH = 0.01

FAILURE_FRACTION_OF_HEIGHT = 0.005
"""Default failure displacement as a fraction of the slope height (``workflows.fos.verdict``)."""
SLIDE_STOP_FRACTION = 0.1
"""With early_stop, a run ends once its largest displacement passes this fraction of the slope height."""
MAX_FAILURE_FRACTION_OF_HEIGHT = 0.5
"""Largest accepted failure displacement, a fraction of the slope height: a slide arrests (or the run
stops it) long before it moves half the slope's height, so a run could never be judged failed."""
FLOOR_PER_FAILURE = 1000.0
"""Default displacement floor: the failure displacement over this."""

RAMP_RESPONSE_TIMES = 4.0
"""Default ``ramp_time_s``: this many response times of the slope (at most half of ``duration_s``)."""

ELASTIC_RESPONSE = 0.0015
"""The elastic response gamma H / (2 G) of the runs, a fraction of the slope height (module doc): the
contained displacement then stays under half the failure displacement up to the FOS on the
published slopes, the undrained one on a deep foundation included (docs/method.md, section 9)."""
MAX_TOLERANCE = 1e-4
"""Largest accepted ``tolerance``: a looser unbalanced-force ratio ends a run before the slope has
responded to its reduced strength (docs/verification.md)."""

MIN_SPACINGS_PER_HEIGHT = 4
"""A strength-reduction study needs at least this many particle spacings over the slope height."""


def _for(field: str) -> str:
    """The reference's note of a field that applies to some protocols only: ``*protocol = ramp or sudden:*``
    (the protocols whose ``fields`` name it)."""
    return f"*protocol = {' or '.join(name for name, each in PROTOCOLS.items() if field in each.fields)}:*"


def _or_default(field: str, default: float) -> property:
    """The value of a protocol's optional ``field``, or its ``default`` where the file leaves it out."""
    return property(lambda stage: default if getattr(stage, field) is None else getattr(stage, field),
                    doc=f"``{field}``, default {default:g}")


@dataclass(frozen=True, kw_only=True)
class StrengthReductionStage(StageBase):
    """Strength reduction: one run per SRF F from the previous stage's stresses with c / F and
    tan(phi) / F; the FOS is where the SRF-displacement curve turns up (last stage only)."""

    kind: ClassVar[str] = "strength_reduction"
    duration_field: ClassVar[str] = "duration_s"
    snapshotted: ClassVar[bool] = False  # ``python -m workflows.output.paraview OUT`` gives the runs' final states
    duration_s: float = number(
        "s", "longest simulated time of each SRF run; with early_stop a run ends once at rest or once it has "
        f"slid {SLIDE_STOP_FRACTION:.0%} of the slope height", gt=0.0,
    )
    protocol: str = text(
        "how the strength is reduced: "
        + "; ".join(f"`{name}`: {protocol.description}" for name, protocol in PROTOCOLS.items())
        + " (docs/verification.md compares them)", default="quasi_static", choices=tuple(PROTOCOLS),
    )
    damping: float | None = number(
        "1", f"{_for('damping')} local (Cundall) damping factor; default {DEFAULT_QUASI_STATIC_DAMPING:g}",
        default=None, gt=0.0, lt=1.0,
    )
    tolerance: float | None = number(
        "1", f"{_for('tolerance')} at rest once the unbalanced-force ratio is below this; default "
        f"{DEFAULT_QUASI_STATIC_TOLERANCE:g}; at most {MAX_TOLERANCE:g} (a looser ratio ends a run before the "
        "slope has responded)", default=None, gt=0.0, le=MAX_TOLERANCE,
    )
    ramp_time_s: float | None = number(
        "s", f"{_for('ramp_time_s')} the strength falls from full to c / F, tan(phi) / F over this time; default "
        f"{RAMP_RESPONSE_TIMES:g} response times of the slope, {4 * RAMP_RESPONSE_TIMES:g} H_domain / V_s",
        default=None, gt=0.0,
    )
    flow_rule: str = text(
        "; ".join(f"`{name}`: {rule.description}" for name, rule in FLOW_RULES.items()),
        default="associated", choices=tuple(FLOW_RULES),
    )
    srf_min: float = number(
        "1", "first SRF of the sweep; below 1 tests whether the slope stands as built", ge=0.01,
    )
    srf_max: float = number("1", "last SRF of the sweep", gt=0.0)
    srf_step: float = number(
        "1", "SRF step of the first sweep (refined around the knee afterwards; SRF values are rounded to 1e-4)",
        ge=0.001,
    )
    fos_tolerance: float = number(
        "1", "refine until the FOS bracket is at most this wide", default=0.01, gt=0.0
    )
    max_runs: int = integer("never make more SRF runs than this", default=40, ge=3, le=1000)
    slope_height_m: float | None = number(
        "m", "height H of the slope, the scale of failure; default: the relief of the free surface, the highest "
        "minus the lowest point of the polygon's upper boundary (crest above toe)", default=None, gt=0.0,
    )
    failure_displacement_m: float | None = number(
        "m", "a run whose largest displacement exceeds this has failed: a mechanism formed and moved; "
        f"default: {FAILURE_FRACTION_OF_HEIGHT:.1%} of the slope height", default=None, gt=0.0,
    )
    displacement_floor_m: float | None = number(
        "m", "displacements below this count as this in the log-scale curve (no mechanism); "
        f"default: failure_displacement_m / {FLOOR_PER_FAILURE:g}", default=None, gt=0.0,
    )
    rest_window_s: float | None = number(
        "s", f"{_for('rest_window_s')} at rest: the largest displacement grew by less than rest_growth of "
        f"itself over the last window, and by less than over the window before; default {DEFAULT_REST_WINDOW_S}",
        default=None, gt=0.0,
    )
    rest_growth: float | None = number(
        "1", f"{_for('rest_growth')} see rest_window_s; default {DEFAULT_REST_GROWTH:g}", default=None, gt=0.0,
        lt=1.0,
    )
    scale_stiffness: bool = boolean(
        "run at moduli scaled so that the slope's elastic response gamma H^2 / (2 G) is "
        f"{ELASTIC_RESPONSE:.2%} of H (the FOS of a perfectly plastic slope does not depend on them; the "
        "verdicts then do not either); false: the declared moduli", default=True,
    )
    early_stop: bool = boolean(
        f"end a run once it is at rest or once it has slid {SLIDE_STOP_FRACTION:.0%} of the slope height",
        default=True,
    )

    def check(self):
        super().check()
        if self.srf_max < self.srf_min:
            raise StudyError("srf_max", f"must be >= srf_min = {self.srf_min:g}, got {self.srf_max:g}")
        if self.srf_step > self.srf_max - self.srf_min and self.srf_max > self.srf_min:
            raise StudyError("srf_step", f"must be <= srf_max - srf_min = {self.srf_max - self.srf_min:g}")
        if (self.srf_max - self.srf_min) / self.srf_step > 200:
            raise StudyError("srf_step", "gives more than 200 sweep values; use a coarser step (the knee is refined)")
        if self.elastic:
            raise StudyError("elastic", "must be false: a strength-reduction stage needs a plastic material")
        if self.start != ORIGINAL_POSITIONS:
            raise StudyError("start", "must be 'original_positions': every SRF run starts from the gravity state")
        for name in OPTIONAL_PROTOCOL_FIELDS:
            if getattr(self, name) is not None and name not in self.reduction.fields:
                protocols = [each for each, protocol in PROTOCOLS.items() if name in protocol.fields]
                raise StudyError(name, f"applies to protocol = {' or '.join(protocols)} only, not {self.protocol}")
        self.reduction.check(self)

    @property
    def reduction(self) -> Protocol:
        """The protocol ``protocol`` names (``workflows.stages.protocols``)."""
        return PROTOCOLS[self.protocol]

    @property
    def dilation_rule(self) -> FlowRule:
        """The flow rule ``flow_rule`` names (``workflows.stages.flow_rules``)."""
        return FLOW_RULES[self.flow_rule]

    def check_in_study(self, study, index: int) -> None:
        """The last stage, after a stage that makes the gravity state, in a study with a plastic
        material, no runout stage and no collapse metrics."""
        if index != len(study.stages) - 1:
            raise StudyError(f"stages[{index}].kind", "a strength_reduction stage must be the last stage")
        if index == 0:
            raise StudyError(
                f"stages[{index}].kind",
                "a strength_reduction stage starts from a gravity state: put a relaxation stage before it",
            )
        if not any(m.plastic for m in study.materials):
            raise StudyError("materials", "a strength_reduction stage needs a material with strength (c, phi)")
        if any(stage.follows_runout for stage in study.stages):
            raise StudyError("stages", "runout stages and a strength_reduction stage belong in separate studies")
        if study.metrics is not None:
            raise StudyError("metrics", "collapse metrics do not apply to a strength_reduction study")
        if not any(study.loads.gravity_m_s2) and not study.loads.surface_loads() and study.water is None:
            raise StudyError("loads.gravity_m_s2", "is zero and no surface load or water acts: nothing loads the "
                             "slope, so no strength reduction can make it fail; give gravity, e.g. [0.0, -9.81]")
        height = study.slope_height_m
        failure, floor = self.failure_m(height), self.floor_m(height)
        if failure >= MAX_FAILURE_FRACTION_OF_HEIGHT * height:
            raise StudyError(f"stages[{index}].failure_displacement_m",
                             f"{failure:g} m is at least {MAX_FAILURE_FRACTION_OF_HEIGHT:g} of the slope height "
                             f"{height:g} m: a slide arrests before it moves that far, so no run could fail; the "
                             f"default is {FAILURE_FRACTION_OF_HEIGHT:g} H = {FAILURE_FRACTION_OF_HEIGHT * height:g} m")
        if floor >= failure:
            default = "" if self.failure_displacement_m is not None else f", {FAILURE_FRACTION_OF_HEIGHT:g} H by default"
            raise StudyError(f"stages[{index}].displacement_floor_m",
                             f"must be < failure_displacement_m = {failure:g} m{default}, got {floor:g}")
        response_s = self.response_time_s(study)
        if self.duration_s < response_s:
            raise StudyError(f"stages[{index}].duration_s",
                             f"{self.duration_s:g} s is shorter than the slope's response time {response_s:.3g} s "
                             "(4 H_domain / V_s): no run could come to rest or slide in it; give several response "
                             f"times, e.g. {10 * response_s:.2g} s")

    def check_resolution(self, study) -> None:
        """StudyError on ``geometry.spacing_m`` when the slope height spans fewer than
        ``MIN_SPACINGS_PER_HEIGHT`` spacings (no mechanism can form across a handful of particles)."""
        height = study.slope_height_m
        if height < MIN_SPACINGS_PER_HEIGHT * study.geometry.spacing_m:
            raise StudyError(
                "geometry.spacing_m",
                f"{study.geometry.spacing_m:g} m: the slope height {height:g} m spans fewer than "
                f"{MIN_SPACINGS_PER_HEIGHT} spacings; make it at most {height / MIN_SPACINGS_PER_HEIGHT:g} m "
                "(10 or more spacings give an FOS within a few per cent, docs/verification.md)",
            )

    # ------------------------------------------------------------------ defaults
    rest_window_s_or_default = _or_default("rest_window_s", DEFAULT_REST_WINDOW_S)
    rest_growth_or_default = _or_default("rest_growth", DEFAULT_REST_GROWTH)
    damping_or_default = _or_default("damping", DEFAULT_QUASI_STATIC_DAMPING)
    tolerance_or_default = _or_default("tolerance", DEFAULT_QUASI_STATIC_TOLERANCE)

    def failure_m(self, slope_height_m: float) -> float:
        """``failure_displacement_m``, default ``FAILURE_FRACTION_OF_HEIGHT`` of the slope height."""
        if self.failure_displacement_m is not None:
            return self.failure_displacement_m
        return FAILURE_FRACTION_OF_HEIGHT * slope_height_m

    def floor_m(self, slope_height_m: float) -> float:
        """``displacement_floor_m``, default the failure displacement / ``FLOOR_PER_FAILURE``."""
        if self.displacement_floor_m is not None:
            return self.displacement_floor_m
        return self.failure_m(slope_height_m) / FLOOR_PER_FAILURE

    @staticmethod
    def response_time_s(study, stiffness_factor: float = 1.0) -> float:
        """T = 4 H_domain / V_s, the fundamental period of a soil layer as thick as the domain on a rigid
        base, with the shear-wave speed V_s = sqrt(s G / rho) of the softest material (moduli times
        ``stiffness_factor`` s): the time a disturbance takes to cross the slope and come back, twice."""
        ys = [y for _, y in study.geometry.polygon_m]
        speed = min(math.sqrt(stiffness_factor * m.youngs_modulus_pa / (2.0 * (1.0 + m.poisson_ratio)) / m.density_kg_m3)
                    for m in study.materials)
        return 4.0 * (max(ys) - min(ys)) / speed

    def ramp_time_s_or_default(self, study) -> float:
        """``ramp_time_s``, default ``RAMP_RESPONSE_TIMES`` response times, at most half of ``duration_s``."""
        if self.ramp_time_s is not None:
            return self.ramp_time_s
        return min(RAMP_RESPONSE_TIMES * self.response_time_s(study), 0.5 * self.duration_s)

    # ------------------------------------------------------------------ before a run
    def materials(self, table):
        """The declared strength: each run reduces it (:meth:`reduced`)."""
        return table

    def acceleration_m_s2(self, study) -> np.ndarray:
        """Gravity with the pseudo-static seismic part, which acts in every run."""
        return study.loads.acceleration_m_s2(study.geometry.polygon_m, strength_reduction=True)

    def stiffness_factor(self, table, study) -> float:
        """s = max_k (rho_k |g| H / (2 G_k)) / ELASTIC_RESPONSE over the rows of ``table``
        (a ``MaterialTable``; module doc); 1 without ``scale_stiffness`` or with a softening material."""
        gravity = float(np.hypot(*study.loads.gravity_m_s2))
        if not self.scale_stiffness or table.softens() or not gravity > 0.0:  # no weight: no response to scale
            return 1.0
        response = np.max(table.density_kg_m3 * gravity * study.slope_height_m / (2.0 * table.shear_modulus_pa))
        return float(response) / ELASTIC_RESPONSE

    def reduced(self, table, srf: float):
        """``table`` with the strength divided by ``srf`` under the stage's flow rule."""
        return self.dilation_rule.reduced(table, srf)

    # ------------------------------------------------------------------ one run
    def run_at(self, sim, srf: float, study, monitor_nodes, stop):
        """The run of one SRF value on ``sim`` (set up for the stage) by the stage's protocol (module
        doc), asking ``stop`` (a ``Simulation`` stop rule) between compiled calls; its TimeSeries."""
        record = dict(record_interval_s=self.record_interval_s, monitor_nodes=monitor_nodes, stop=stop)
        declared = sim.particle_materials
        factor = self.stiffness_factor(declared, study)
        if factor != 1.0:
            declared = declared.with_moduli_scaled(factor)
        return self.reduction.run(self, sim, declared, srf, study, record)
