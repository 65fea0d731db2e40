"""FORM on the FOS (``method = "form"``, ``workflows.probabilistic.form``): iteration k searches the FOS
at its centre ``u_k`` and at ``u_k + form_step e_i`` (n + 1 points, a round), linearises ``g = FOS - factor``
and moves to the linearisation's point nearest the origin, until beta changes by at most
``form_tolerance``; the first iteration, at the mean, is the FOSM index (``design_points``: what the
methods that place their points share).  With ``sorm = true``, one more round once FORM has converged: g
about the design point by central differences of ``sorm_step`` along the tangent axes and the normal
(``workflows.probabilistic.sorm``: 1 + 2(n-1)^2 + 2 points), its principal curvatures and pf by Breitung and
by Hohenbichler-Rackwitz.  Where the curvatures allow no second-order estimate (some 1 + beta kappa <= 0, a
point without a FOS, the budget spent) the report says why and FORM's beta stands; where they lie within their
noise (the searches' brackets) the report says so beside SORM's range.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.probabilistic import form, sorm
from workflows.probabilistic.design_points import NOISE_BRACKETS, DesignPointOutcome, DesignPoints, DesignPointStudy
from workflows.probabilistic.kinds import sorm_searches
from workflows.probabilistic.study_type import FIRST_REALISATIONS
from workflows.study import Study


@dataclass(frozen=True)
class SecondOrder:
    """What SORM found (module doc): pf by Breitung and by Hohenbichler-Rackwitz (None: no second-order estimate,
    ``status`` says why; FORM's stands), the principal curvatures and their noise bound, the FOS searches spent."""

    status: str = ""  # why there is no SORM estimate ("": there is)
    pf_breitung: float | None = None
    pf_hr: float | None = None
    kappas: tuple = ()
    noise: float = math.nan
    pf_range: tuple = (None, None)  # Breitung's pf with the curvatures raised, lowered by their noise
    gradient_angle_deg: float = math.nan  # between the gradient at u* and the normal: 0 at the design point
    fos_at_design_point: float = math.nan  # the FOS at FORM's u* (the last plane's point nearest the origin)
    searches: int = 0
    step: float = math.nan

    @property
    def beta_breitung(self) -> float:
        return math.nan if self.pf_breitung is None else sorm.index(self.pf_breitung)

    @property
    def beta_hr(self) -> float:
        return math.nan if self.pf_hr is None else sorm.index(self.pf_hr)

    @property
    def within_noise(self) -> bool:
        """Every curvature within its noise bound: the correction is not resolved."""
        return bool(self.kappas) and all(abs(kappa) <= self.noise for kappa in self.kappas)

    def line(self, beta_form: float) -> str:
        """The report's SORM line."""
        if self.pf_breitung is None:
            return f"SORM: no second-order estimate ({self.status}); FORM's beta = {beta_form:.3f} stands"
        if not self.kappas:
            return (f"SORM: one variable, no tangent plane: pf_SORM = pf_FORM = {self.pf_breitung:.3g} (beta "
                    f"{beta_form:.3f}); no FOS search spent")
        low, high = self.pf_range
        spread = (f"beta_SORM {sorm.index(high):.3f} to {sorm.index(low):.3f}" if high is not None and low is not None
                  else "the lowered curvatures break 1 + beta kappa > 0: beta_SORM unbounded below")
        hr = (f"beta = {self.beta_hr:.3f}, pf {self.pf_hr:.3g}" if self.pf_hr is not None
              else "none (1 + psi kappa <= 0)")
        line = (f"SORM (Breitung 1984) beta = {self.beta_breitung:.3f}, pf_SORM = {self.pf_breitung:.3g}; "
                f"Hohenbichler-Rackwitz {hr} (FORM's {beta_form:.3f}); "
                f"principal curvatures {', '.join(f'{kappa:+.4f}' for kappa in self.kappas)} per standard "
                f"deviation, each +- {self.noise:.4f} from the brackets ({spread}); gradient at u* "
                f"{self.gradient_angle_deg:.1f} deg off the normal, FOS there {self.fos_at_design_point:.4f}; "
                f"{self.searches} FOS searches at sorm_step {self.step:g}")
        if self.within_noise:
            line += ("; every curvature within its noise: the second-order correction is not resolved (a larger "
                     "sorm_step or a smaller fos_tolerance), FORM's beta as good")
        return line


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
    second_order: SecondOrder | None = None  # SORM's, where ``sorm`` asked for it

    @property
    def verdict(self) -> str:
        if not math.isfinite(self.beta):
            return f"FORM: no reliability index ({self.stop_reason})"
        second = self.second_order
        return (f"FORM reliability index beta = {self.beta:.3f} (pf_FORM = Phi(-beta) = "
                f"{form.failure_probability(self.beta):.3g}), " + ("converged" if self.converged else
                                                                     f"NOT converged: {self.stop_reason}")
                + f" after {self.iterations} iterations; FOSM at the mean: beta = {self.beta_fosm:.3f}"
                + (f"; SORM beta = {second.beta_breitung:.3f}" if second is not None and second.pf_breitung is not None
                   else ""))


class FormStudy(DesignPointStudy):
    """A study with ``[probabilistic]`` and ``method = "form"`` (module doc)."""

    outcome_type = FormOutcome

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.iterations: list[form.Linearisation] = []
        self.noisy: set[int] = set()
        self.sorm_start: int | None = None  # the first point of SORM's round, once made
        self.second_order: SecondOrder | None = None

    def make_realisations(self) -> DesignPoints:
        """The first iteration's points, about the mean."""
        points = DesignPoints(self.study)
        points.add_u(form.gradient_points(np.zeros(len(points.marginals)), self.study.probabilistic.form_step))
        return points

    def _round_note(self) -> str:
        return ", SORM's round" if self.sorm_start is not None else f", iteration {len(self.iterations) + 1}"

    def next_cases(self, outcomes: dict, progress) -> list:
        """FORM's next iteration, once the last one's points are searched (module doc); none when beta has
        converged (but SORM's round, ``sorm``), a point has no FOS, or the budget is spent."""
        table = self.study.probabilistic
        if self.finished:
            return []
        points = self.realisations
        fos, brackets = self._fos_of_round(outcomes)
        if self.sorm_start is not None:
            self.second_order = self._second_order(fos, brackets)
            self.finished = True
            return []
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
            if table.sorm and self._place_sorm_round(progress):
                return self.more_cases(FIRST_REALISATIONS)
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

    def _place_sorm_round(self, progress) -> bool:
        """SORM's points about the converged design point (module doc), True once placed; none for one variable
        (SORM is FORM there) or where the budget has no room for them (``second_order`` says so)."""
        points = self.realisations
        last = self.iterations[-1]
        n = len(points.marginals)
        step = self.study.probabilistic.sorm_step
        if n == 1:
            pf = form.failure_probability(last.beta)
            self.second_order = SecondOrder(pf_breitung=pf, pf_hr=pf, pf_range=(pf, pf), step=step)
            return False
        count = sorm_searches(n)
        if points.count + count > points.budget:
            self.second_order = SecondOrder(status=f"its {count} FOS searches do not fit the budget of {points.budget} "
                                            f"(realisations) after FORM's {points.count}", step=step)
            return False
        progress.message(f"FORM converged: beta {last.beta:.4f}; SORM's {count} points about the design point")
        self.round_start = self.sorm_start = points.count
        points.add_u(sorm.curvature_points(last.next_u, step))
        self.batch_end = points.count
        return True

    def _second_order(self, fos: np.ndarray, brackets: np.ndarray) -> SecondOrder:
        """SORM from its round's FOS values and brackets (module doc)."""
        assert self.sorm_start is not None
        table = self.study.probabilistic
        points = self.realisations
        step, count = table.sorm_step, len(fos)
        if not np.isfinite(fos).all():
            bad = points.case_id(self.sorm_start + int(np.argmin(np.isfinite(fos))))
            return SecondOrder(status=f"{bad} has no FOS within its search", searches=count, step=step)
        last = self.iterations[-1]
        shape = sorm.Curvatures.of(last.next_u, fos - table.factor, step, 0.5 * brackets)
        angle = math.degrees(math.acos(min(1.0, abs(shape.gradient[-1]) / shape.gradient_norm)))
        if not shape.outward:
            return SecondOrder(status="the FOS does not fall outward through the design point: no limit state to "
                               "curve", searches=count, step=step, gradient_angle_deg=angle,
                               fos_at_design_point=float(fos[0]))
        kappas = shape.kappas
        breitung = sorm.breitung(last.beta, kappas)
        found = SecondOrder(kappas=tuple(map(float, kappas)), noise=shape.noise, searches=count, step=step,
                            gradient_angle_deg=angle, fos_at_design_point=float(fos[0]))
        if breitung is None:
            worst = float(kappas.min())
            return dataclasses.replace(found, status=(
                f"1 + beta kappa = {1 + last.beta * worst:.3f} <= 0 for the curvature {worst:+.4f} per standard "
                f"deviation (+- {shape.noise:.4f}): the limit state curves toward the origin as much as the sphere "
                "of radius beta, Breitung's asymptote does not exist"))
        return dataclasses.replace(found, pf_breitung=breitung, pf_hr=sorm.hohenbichler_rackwitz(last.beta, kappas),
                                   pf_range=sorm.range_from_noise(last.beta, kappas, shape.noise))

    def _method_results(self, result: FormOutcome, ds, attrs: dict):  # type: ignore[override]
        """beta, the design point and alpha into ``result``, ``ds`` (returned) and its ``attrs``."""
        from workflows.output.variables import PROBABILISTIC_FILE as var

        points = self.realisations
        self._form_result(result)
        iteration = ds["realisation"].values // (len(points.labels) + 1)
        if self.sorm_start is not None:
            iteration[ds["realisation"].values >= self.sorm_start] = -1
        ds["form_iteration"] = var["form_iteration"](iteration)
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
        second = result.second_order = self.second_order
        if second is not None:
            attrs.update(sorm_status=second.status, sorm_searches=second.searches, sorm_step=second.step)
            if second.kappas:
                attrs.update(sorm_curvatures=" ".join(f"{kappa:.6g}" for kappa in second.kappas),
                             sorm_curvature_noise=second.noise, sorm_gradient_angle_deg=second.gradient_angle_deg)
            if second.pf_breitung is not None:
                attrs.update(reliability_index_sorm=second.beta_breitung, pf_sorm=second.pf_breitung)
            if second.pf_hr is not None:
                attrs.update(reliability_index_sorm_hr=second.beta_hr, pf_sorm_hr=second.pf_hr)
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
        if self.study.probabilistic.sorm:
            lines.append(outcome.second_order.line(outcome.beta) if outcome.second_order is not None else
                         "SORM: its round did not finish" if self.sorm_start is not None else
                         "SORM: not run (FORM did not converge)")
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
