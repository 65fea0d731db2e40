"""How one strength-reduction run ended: stable, failed or diverged.

- ``failed``: the largest displacement passed ``failure_displacement_m``, or the run was
  still moving at the end (the running maximum of the displacement grew by more than
  ``rest_growth`` of itself over the last ``rest_window_s`` and not less than over the
  window before);
- ``stable``: otherwise (and a run that came to rest early);
- ``diverged``: the solver detected a blow-up; the run is left out of the curve.

The same rules stop a run early (:meth:`Verdict.stop_rule`): once past the failure
displacement, or at rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.study import StrengthReductionStage, Study

STABLE = "stable"
FAILED = "failed"
DIVERGED = "diverged"


def failure_displacement_m(study: Study) -> float:
    """The stage's ``failure_displacement_m``, default 10% of the height of the domain."""
    stage = study.strength_reduction
    if stage.failure_displacement_m is not None:
        return stage.failure_displacement_m
    ys = [y for _, y in study.geometry.polygon_m]
    return 0.1 * (max(ys) - min(ys))


def displacement_floor_m(study: Study) -> float:
    """The stage's ``displacement_floor_m``, default failure_displacement_m / 1000."""
    stage = study.strength_reduction
    if stage.displacement_floor_m is not None:
        return stage.displacement_floor_m
    return failure_displacement_m(study) / 1000.0


def _window_growth(time_s: np.ndarray, max_u_m: np.ndarray, window_s: float) -> tuple[float, float, float]:
    """(u now, growth over the last window, growth over the window before) of the running
    maximum of the largest displacement."""
    running = np.maximum.accumulate(max_u_m)
    t = time_s[-1]
    u_now = float(running[-1])
    u_1 = float(np.interp(t - window_s, time_s, running))
    u_2 = float(np.interp(t - 2.0 * window_s, time_s, running))
    return u_now, u_now - u_1, u_1 - u_2


@dataclass(frozen=True)
class Verdict:
    """How one run ended."""

    failure_m: float
    floor_m: float
    window_s: float
    growth: float

    def past_failure(self, max_u_m: np.ndarray) -> bool:
        return bool(max_u_m.size) and float(np.max(max_u_m)) > self.failure_m

    def at_rest(self, time_s, max_u_m) -> bool:
        """Displacement no longer growing: less than ``growth`` of itself per window, and slowing."""
        if time_s[-1] < 2.0 * self.window_s:
            return False
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last <= self.growth * max(u_now, self.floor_m) and last <= before

    def still_moving(self, time_s, max_u_m) -> bool:
        """Displacement still growing at the end (more than ``growth`` per window, not slowing)."""
        if time_s[-1] < 2.0 * self.window_s:
            return True
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last > self.growth * max(u_now, self.floor_m) and last >= before

    def stop_rule(self):
        """The early-stop rule handed to ``Simulation.run``."""

        def rule(time_s, max_u_m, kinetic):
            if self.past_failure(max_u_m):
                return f"failed: largest displacement {float(np.max(max_u_m)):.3g} m > {self.failure_m:g} m"
            if self.at_rest(time_s, max_u_m):
                return f"at rest: largest displacement grew < {self.growth:g} of itself in the last {self.window_s:g} s"
            return None

        return rule

    def classify(self, time_s, max_u_m) -> tuple[str, str]:
        """(status, one-line reason) of a finished run."""
        peak = float(np.max(max_u_m))
        if self.past_failure(max_u_m):
            return FAILED, f"largest displacement {peak:.3g} m > failure_displacement_m {self.failure_m:g} m"
        if self.still_moving(time_s, max_u_m):
            _, last, _ = _window_growth(time_s, max_u_m, self.window_s)
            return FAILED, f"still moving at the end: +{last:.3g} m in the last {self.window_s:g} s (not slowing)"
        return STABLE, f"largest displacement {peak:.3g} m, not growing at the end"


def verdict_for(study: Study) -> Verdict:
    stage: StrengthReductionStage = study.strength_reduction
    return Verdict(failure_displacement_m(study), displacement_floor_m(study), stage.rest_window_s, stage.rest_growth)
