"""FORM on the FOS (``method = "form"``, ``workflows.probabilistic.form``): iteration k searches the FOS
at its centre ``u_k`` and at ``u_k + form_step e_i`` (n + 1 points, a round), linearises ``g = FOS - factor``
and moves to the linearisation's point nearest the origin, until beta changes by at most
``form_tolerance``; the first iteration, at the mean, is the FOSM index (``design_points``: what the
methods that place their points share).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.probabilistic import form
from workflows.probabilistic.design_points import NOISE_BRACKETS, DesignPointOutcome, DesignPoints, DesignPointStudy
from workflows.probabilistic.study_type import FIRST_REALISATIONS
from workflows.study import Study


@dataclass
class FormOutcome(DesignPointOutcome):
    """What FORM found (module doc)."""

    beta: float = math.nan  # the reliability index
    beta_fosm: float = math.nan  # the first iteration's, at the mean
    iterations: int = 0
    converged: bool = False
    design_point: dict = dataclasses.field(default_factory=dict)  # variable -> value at u*
    alpha: dict = dataclasses.field(default_factory=dict)  # variable -> sensitivity factor
    noisy: list = dataclasses.field(default_factory=list)  # variables whose step was within the noise
    discretised: tuple | None = None  # (low excess, high excess, beta at h -> 0 for each)

    @property
    def verdict(self) -> str:
        if not math.isfinite(self.beta):
            return f"FORM: no reliability index ({self.stop_reason})"
        return (f"FORM reliability index beta = {self.beta:.3f} (pf_FORM = Phi(-beta) = "
                f"{form.failure_probability(self.beta):.3g}), " + ("converged" if self.converged else
                                                                     f"NOT converged: {self.stop_reason}")
                + f" after {self.iterations} iterations; FOSM at the mean: beta = {self.beta_fosm:.3f}")


class FormStudy(DesignPointStudy):
    """A study with ``[probabilistic]`` and ``method = "form"`` (module doc)."""

    outcome_type = FormOutcome

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.iterations: list[form.Linearisation] = []
        self.noisy: set[int] = set()

    def make_realisations(self) -> DesignPoints:
        """The first iteration's points, about the mean."""
        points = DesignPoints(self.study)
        points.add_u(form.gradient_points(np.zeros(len(points.marginals)), self.study.probabilistic.form_step))
        return points

    def _round_note(self) -> str:
        return f", iteration {len(self.iterations) + 1}"

    def next_cases(self, outcomes: dict, progress) -> list:
        """FORM's next iteration, once the last one's points are searched (module doc); none when beta has
        converged, a point has no FOS, or the budget is spent."""
        table = self.study.probabilistic
        if self.finished:
            return []
        points = self.realisations
        fos, brackets = self._fos_of_round(outcomes)
        if not np.isfinite(fos).all():
            bad = self.round_start + int(np.argmin(np.isfinite(fos)))
            self.stop_reason = f"{points.case_id(bad)} has no FOS within its search"
            self.finished = True
            return []
        step = table.form_step
        self.iterations.append(form.Linearisation.of(points.u[self.round_start], fos - table.factor, step))
        self.noisy |= set(form.noisy_variables(fos, brackets, NOISE_BRACKETS))
        betas = [linearisation.beta for linearisation in self.iterations]
        if form.converged(betas, table.form_tolerance):
            self.finished = True
            return []
        n = len(points.marginals)
        if points.count + n + 1 > points.budget:
            self.stop_reason = f"the budget of {points.budget} FOS searches (realisations) is spent"
            self.finished = True
            return []
        progress.message(f"FORM iteration {len(self.iterations)}: beta {betas[-1]:.4f}")
        self.round_start = points.count
        points.add_u(form.gradient_points(self.iterations[-1].next_u, step))
        self.batch_end = points.count
        return self.more_cases(FIRST_REALISATIONS)

    def _method_results(self, result: FormOutcome, ds, attrs: dict):  # type: ignore[override]
        """beta, the design point and alpha into ``result``, ``ds`` (returned) and its ``attrs``."""
        from workflows.output.variables import PROBABILISTIC_FILE as var

        points = self.realisations
        self._form_result(result)
        ds["form_iteration"] = var["form_iteration"](ds["realisation"].values // (len(points.labels) + 1))
        ds["design_point"] = var["design_point"](np.array([result.design_point.get(label, math.nan)
                                                           for label in points.labels]))
        ds["sensitivity_alpha"] = var["sensitivity_alpha"](np.array([result.alpha.get(label, math.nan)
                                                                     for label in points.labels]))
        if result.discretised is not None:
            attrs.update(form_discretisation_excess=f"{result.discretised[0]:.4f} {result.discretised[1]:.4f}",
                         reliability_index_form_at_zero_spacing=f"{result.discretised[2]:.4f} "
                                                                f"{result.discretised[3]:.4f}")
        attrs.update(reliability_index_form=result.beta, pf_form=form.failure_probability(result.beta),
                     reliability_index_fosm=result.beta_fosm, form_iterations=result.iterations,
                     form_converged=int(result.converged), form_stop_reason=result.stop_reason)
        return ds

    def _form_result(self, result: FormOutcome) -> None:
        """beta, the design point, alpha and the stop of FORM's iterations (module doc)."""
        points = self.realisations
        result.iterations = len(self.iterations)
        result.stop_reason = self.stop_reason
        result.converged = self.finished and not self.stop_reason
        result.noisy = [points.labels[i] for i in sorted(self.noisy)]
        if not self.iterations:
            return
        last = self.iterations[-1]
        result.beta, result.beta_fosm = last.beta, self.iterations[0].beta
        result.design_point = dict(zip(points.labels, map(float, points.x_of(last.next_u))))
        result.alpha = dict(zip(points.labels, map(float, last.alpha)))
        from workflows.fos.discretisation import expected_excess

        expected = expected_excess(self.study)
        if expected is not None:  # g lowered by factor * e: beta - factor e / |grad| on the last linearisation
            norm = float(np.linalg.norm(last.gradient))
            factor = self.study.probabilistic.factor
            result.discretised = (expected[0], expected[1],
                                  *(last.beta - factor * e / norm for e in expected[:2]))

    def _figure(self, ds) -> Path:
        from workflows.probabilistic.design_point_figures import draw_form  # matplotlib: on use

        return draw_form(self.out_dir, ds, self.study.probabilistic.factor)

    def _report_lines(self, outcome: FormOutcome) -> list[str]:  # type: ignore[override]
        """The design point, alpha, the discretisation's share and the noisy variables."""
        lines: list[str] = []
        if not outcome.design_point:
            return lines
        lines.append("design point: " + ", ".join(f"{k} {v:.5g}" for k, v in outcome.design_point.items())
                     + "; sensitivity alpha: " + ", ".join(f"{k} {v:+.3f}" for k, v in outcome.alpha.items()))
        if outcome.discretised is not None:
            low, high, beta_low, beta_high = outcome.discretised
            lines.append(f"discretisation (apart from beta above): every FOS expected {100 * low:.1f}% to "
                         f"{100 * high:.1f}% above its value at h -> 0, so beta at h -> 0 about {beta_high:.3f} to "
                         f"{beta_low:.3f} (pf_FORM {form.failure_probability(beta_low):.3g} to "
                         f"{form.failure_probability(beta_high):.3g}): g = FOS - factor lowered by factor x excess "
                         "on the last linearisation")
        if outcome.noisy:
            lines.append(f"note: the step of {', '.join(outcome.noisy)} changed the FOS by less than "
                         f"{NOISE_BRACKETS:g} brackets of its searches: its alpha is noise (a larger form_step, "
                         "or a smaller fos_tolerance)")
        return lines
