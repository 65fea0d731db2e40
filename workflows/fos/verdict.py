"""How one strength-reduction run ended: stable, failed or diverged.

A run starts from the gravity state with the strength divided by F.  Its largest particle
displacement u (the running maximum over the run) is compared with the failure displacement
u_fail, by default 0.5% of the slope height H (``Study.slope_height_m``):

- ``failed``: a mechanism formed and moved: u > u_fail.  Large deformation lets a slide
  stop again once the moved ground has found a new equilibrium; such an arrested slide is a
  failure of the original geometry, and the reason says how far it moved.  A run that is
  still moving at its end, below u_fail, has failed as well: no equilibrium was found
  (quasi-static: the unbalanced force did not converge within ``duration_s``; undamped: the
  displacement was still growing without slowing).
- ``stable``: the slope came to rest with u <= u_fail, a displacement of the order of the
  contained elastic-plastic response (quasi-static: unbalanced-force ratio below
  ``tolerance``; undamped: the displacement stopped growing, see :meth:`Verdict.at_rest`).
- ``diverged``: the solver detected a blow-up; the run is left out of both criteria.

Why 0.5% of H.  Above the FOS F*, the arrested displacement grows about linearly with the
excess strength deficit, u ~ H (F - F*) / F* on the reference slope (docs/method.md); below
it, the contained response of a slope with realistic stiffness stays below about 0.3% of H
up to F* (0.2% at E = 100 MPa, H = 10 m, phi = 20 deg).  A threshold of 0.5% H therefore
separates the two within about 0.005 of F*, where the FOS bracket of the curve lies.

The same rules stop a run early (:meth:`Verdict.stop_rule`): at rest, or once the slide has
moved ``SLIDE_STOP_FRACTION`` of H, at least twice u_fail (a failure no longer in doubt; the
run goes no further).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.stages.strength_reduction import SLIDE_STOP_FRACTION
from workflows.study import Study

STABLE = "stable"
FAILED = "failed"
DIVERGED = "diverged"


def failure_displacement_m(study: Study) -> float:
    """The stage's ``failure_displacement_m``, by default a fraction of the slope height
    (``strength_reduction.FAILURE_FRACTION_OF_HEIGHT``)."""
    return study.strength_reduction.failure_m(study.slope_height_m)


def displacement_floor_m(study: Study) -> float:
    """The stage's ``displacement_floor_m``, default failure_displacement_m / 1000."""
    return study.strength_reduction.floor_m(study.slope_height_m)


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
    """The rules of the module doc for one study: its thresholds and its protocol."""

    failure_m: float
    slide_stop_m: float
    floor_m: float
    rest_by_unbalanced_force: bool  # at rest = converged unbalanced force (quasi_static); else = displacement
    # stopped growing (the protocol's ``rest_by_unbalanced_force``)
    window_s: float
    growth: float

    def past(self, max_u_m: np.ndarray, threshold_m: float) -> bool:
        return bool(max_u_m.size) and float(np.max(max_u_m)) > threshold_m

    def at_rest(self, time_s, max_u_m) -> bool:
        """Undamped runs: the displacement no longer grows (less than ``growth`` of itself over the
        last window) and slows down."""
        if time_s[-1] < 2.0 * self.window_s:
            return False
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last <= self.growth * max(u_now, self.floor_m) and last <= before

    def still_moving(self, time_s, max_u_m) -> bool:
        """Undamped runs: the displacement still grows at the end (more than ``growth`` of itself
        over the last window) and does not slow down."""
        if time_s[-1] < 2.0 * self.window_s:
            return True
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last > self.growth * max(u_now, self.floor_m) and last >= before

    def stop_rule(self, at_failure: bool = False):
        """The early-stop rule handed to the simulation: slid past ``slide_stop_m``, or (undamped)
        at rest.  A quasi-static run also ends by itself once the unbalanced force converges.
        ``at_failure``: end as soon as the run has failed, past ``failure_m`` (the running maximum
        only grows, so :meth:`classify` says failed whatever follows): for a run of which only the
        verdict is used, a realisation judged by its one run."""
        stop_m = self.failure_m if at_failure else self.slide_stop_m

        def rule(time_s, max_u_m, energy):
            if self.past(max_u_m, stop_m):
                return (f"{'failed' if at_failure else 'slid'}: largest displacement {float(np.max(max_u_m)):.3g} m "
                        f"> {stop_m:g} m")
            if not self.rest_by_unbalanced_force and self.at_rest(time_s, max_u_m):
                return f"at rest: largest displacement grew < {self.growth:g} of itself in the last {self.window_s:g} s"
            return None

        return rule

    def classify(self, time_s, max_u_m, converged: bool | None) -> tuple[str, str]:
        """(status, one-line reason) of a finished run; ``converged``: did a quasi-static run's
        unbalanced force converge (None for undamped runs)."""
        peak = float(np.max(max_u_m))
        rest = bool(converged) if self.rest_by_unbalanced_force else not self.still_moving(time_s, max_u_m)
        if peak > self.failure_m:
            ended = ("came to rest (an arrested slide)" if rest else
                     "still moving" if peak <= self.slide_stop_m else "stopped there")
            return FAILED, (f"a mechanism formed and moved {peak:.3g} m (> failure_displacement_m {self.failure_m:g} m), "
                            f"{ended}")
        if not rest:
            if self.rest_by_unbalanced_force:
                return FAILED, f"no equilibrium within the run: the unbalanced force had not converged at {time_s[-1]:.3g} s"
            _, last, _ = _window_growth(time_s, max_u_m, self.window_s)
            return FAILED, f"still moving at the end: +{last:.3g} m in the last {self.window_s:g} s (not slowing)"
        return STABLE, f"came to rest with a largest displacement of {peak:.3g} m (<= {self.failure_m:g} m)"


def verdict_for(study: Study) -> Verdict:
    stage = study.strength_reduction
    return Verdict(
        failure_m=failure_displacement_m(study),
        slide_stop_m=max(SLIDE_STOP_FRACTION * study.slope_height_m, 2.0 * failure_displacement_m(study)),
        floor_m=displacement_floor_m(study), rest_by_unbalanced_force=stage.reduction.rest_by_unbalanced_force,
        window_s=stage.rest_window_s_or_default, growth=stage.rest_growth_or_default,
    )
