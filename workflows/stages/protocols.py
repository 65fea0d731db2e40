"""The protocols of a strength-reduction run, each one object with its behaviour: the optional
fields that apply to it, its own checks, how a run at F goes on a simulation, and how its end is
judged (``workflows.fos.verdict``).  ``[[stages]] protocol`` names one of :data:`PROTOCOLS`; the
protocols themselves are ``workflows.stages.strength_reduction``'s module doc."""

from __future__ import annotations

from workflows.fields import StudyError

RAMP_STEPS = 20
"""A strength ramp changes the materials this many times, evenly over ``ramp_time_s``."""


class Protocol:
    """One protocol of strength reduction."""

    name: str
    description: str  # for the study-file reference
    fields: tuple[str, ...] = ()  # the stage's optional fields that apply to it
    rest_by_unbalanced_force = False  # at rest: the unbalanced force converged (else the displacement stopped growing)

    def check(self, stage) -> None:
        """StudyError naming a field of ``stage`` that does not fit this protocol; none by default."""

    def run(self, stage, sim, declared, srf: float, study, record: dict):
        """The run at ``srf`` on ``sim`` (set up for the stage) from the ``declared`` materials (moduli
        scaled), recording as ``record`` says; its TimeSeries."""
        raise NotImplementedError


class QuasiStatic(Protocol):
    """The reduced strength at once, then dynamic relaxation with local damping until the unbalanced
    force converges or ``duration_s``."""

    name = "quasi_static"
    description = ("at once, with local damping, each run until the unbalanced force converges (a slope at rest) "
                   "or the slope slides")
    fields: tuple[str, ...] = ("damping", "tolerance")
    rest_by_unbalanced_force = True

    def run(self, stage, sim, declared, srf, study, record):
        sim.set_materials(stage.reduced(declared, srf))
        return sim.relax(damping=stage.damping_or_default, tolerance=stage.tolerance_or_default,
                         max_duration_s=stage.duration_s, **record)


class Undamped(Protocol):
    """Undamped dynamics, at rest once the displacement stops growing over ``rest_window_s``."""

    fields: tuple[str, ...] = ("rest_window_s", "rest_growth")

    def check(self, stage) -> None:
        """With early_stop, two rest windows within ``duration_s``."""
        if stage.early_stop and 2 * stage.rest_window_s_or_default > stage.duration_s:
            raise StudyError(
                "rest_window_s",
                f"must be <= duration_s / 2 = {stage.duration_s / 2:g}, got {stage.rest_window_s_or_default:g}",
            )


class Sudden(Undamped):
    """The reduced strength at once, undamped."""

    name = "sudden"
    description = "at once, undamped"

    def run(self, stage, sim, declared, srf, study, record):
        sim.set_materials(stage.reduced(declared, srf))
        return sim.run(stage.duration_s, damping=0.0, **record)


class Ramp(Undamped):
    """The strength falling linearly in 1/F from full to c / F over ``ramp_time_s`` (in
    :data:`RAMP_STEPS` steps), then held, undamped; F <= 1 (a stronger slope than built) at once."""

    name = "ramp"
    description = "gradually over ramp_time_s, undamped"
    fields = ("ramp_time_s", *Undamped.fields)

    def check(self, stage) -> None:
        """The rest windows (:class:`Undamped`), and the ramp within ``duration_s``."""
        super().check(stage)
        if stage.ramp_time_s is not None and stage.ramp_time_s >= stage.duration_s:
            raise StudyError("ramp_time_s", f"must be < duration_s = {stage.duration_s:g}, got {stage.ramp_time_s:g}")

    def run(self, stage, sim, declared, srf, study, record):
        if srf <= 1.0:  # a stronger slope than built: nothing to ramp
            return SUDDEN.run(stage, sim, declared, srf, study, record)
        ramp_s = stage.ramp_time_s_or_default(study)
        step_s = ramp_s / RAMP_STEPS

        def ramp(time_s: float) -> None:
            """Set the strength of the ramp step that starts at ``time_s`` (held constant over it)."""
            fraction = min((time_s + step_s) / ramp_s, 1.0)
            if time_s < ramp_s:
                sim.set_materials(stage.reduced(declared, 1.0 / (1.0 - fraction * (1.0 - 1.0 / srf))))

        ramp(0.0)
        return sim.run(stage.duration_s, damping=0.0, periodic=(step_s, ramp), **record)


QUASI_STATIC, RAMP, SUDDEN = QuasiStatic(), Ramp(), Sudden()
PROTOCOLS: dict[str, Protocol] = {protocol.name: protocol for protocol in (QUASI_STATIC, RAMP, SUDDEN)}
"""Every protocol, by its name in the study file."""
