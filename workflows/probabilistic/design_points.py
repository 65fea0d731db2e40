"""A probabilistic study whose points are placed, not sampled: FORM (``method = "form"``) and the point
estimate method (``method = "point_estimate"``), for random variables, each point's FOS by its search.

- ``form`` (``workflows.probabilistic.form``): iteration k searches the FOS at its centre ``u_k`` and at
  ``u_k + form_step e_i`` (n + 1 points, a round: they run together on the cluster), linearises
  ``g = FOS - factor`` and moves to the linearisation's point nearest the origin, until beta changes by at
  most ``form_tolerance``; the first iteration, at the mean, is the FOSM index.  Points are realisations
  of the study in ``OUT/cases/realisation_<i>/`` (iteration after iteration), each a study with its values
  in the unit of their paths, from ``u`` by the Nataf transform of ``workflows.probabilistic.sampling``.
- ``point_estimate`` (``workflows.probabilistic.point_estimate``): the 2^n points at mean +- std in one
  round, and the FOS's mean and std from Rosenblueth's weights.

Every search is to ``fos_tolerance`` (the stage's, set tighter: FORM's differences must stand above the
FOS's own noise, the search's bracket), from an ``srf_min`` of at most half the factor (the design point
lies at FOS = factor, below the range a study of the mean soil may give).  The points are a function of the FOS values before them
only, so a study stopped part way computes again only what it had not: the points it made are the same,
and their runs are read back from disk.  ``OUT/probabilistic.nc`` lists the points with their FOS (its
pf and running pf are NaN: the points are no sample), beta, the design point, the sensitivity factors or
the point estimates; ``form.png`` or ``point_estimate.png`` draws them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.cases import Case, Report
from workflows.output.figures import remove_stale_figures
from workflows.output.writing import make_output_folder, write_dataset
from workflows.probabilistic import form, point_estimate
from workflows.probabilistic.sampling import Sampler
from workflows.probabilistic.study_type import (
    FIRST_REALISATIONS,
    LARGEST_GENERATION,
    RESULT_NAME,
    ProbabilisticOutcome,
    ProbabilisticStudy,
    Realisations,
)
from workflows.study import Study, StudyError
from workflows.study.reading import resolve_sweep_path
from workflows.sweep.results import CASES_FOLDER, case_result, diverged_result
from workflows.sweep.stale import remove_stale_cases

NOISE_BRACKETS = 3.0
"""A FORM step whose change of the FOS is within this many brackets of its searches gives a noisy
sensitivity: the report names the variable."""
FIGURES = ("form.png", "point_estimate.png", "subset_simulation.png")
SRF_MIN_SHARE = 0.5
"""Each point's search starts at most at this share of the factor (FORM's design point has FOS = factor)."""


class DesignPoints(Realisations):
    """The points of a form or point_estimate study, made round by round (module doc); ``count`` is the
    points made so far, ``budget`` the most (``realisations``)."""

    def __init__(self, study: Study):
        super().__init__(study)
        self.budget = study.probabilistic.realisations
        stage = study.strength_reduction.name
        node, key, _ = resolve_sweep_path(self.raw, f"stages.{stage}.fos_tolerance")
        node[key] = study.probabilistic.fos_tolerance
        node, key, _ = resolve_sweep_path(self.raw, f"stages.{stage}.srf_min")  # FORM's points reach FOS = factor
        node[key] = min(study.strength_reduction.srf_min, SRF_MIN_SHARE * study.probabilistic.factor)

    def _sampled(self) -> np.ndarray:
        """No point yet: the marginals and the Nataf transform (StudyError naming the field)."""
        table = self.study.probabilistic
        self.marginals = [self._marginal(k) for k in range(len(table.variables))]
        self.correlation = (np.eye(len(self.marginals)) if table.correlation is None
                            else np.array(table.correlation, float))
        try:
            self.sampler = Sampler(self.marginals, self.correlation)
        except ValueError as error:
            raise StudyError("probabilistic.correlation", str(error)) from None
        self.u = np.empty((0, len(self.marginals)))
        self.field_terms: dict[int, tuple] = {}  # point -> its fields' (realisation, weight) terms, where not its own
        return np.empty((0, len(self.marginals)))

    def add(self, values: np.ndarray, u: np.ndarray | None = None) -> None:
        """Points with their values (and standard normals ``u``, FORM's), checked against their fields' ranges."""
        values = np.atleast_2d(values)
        self.values = np.vstack([self.values, values])
        self.u = np.vstack([self.u, np.full(values.shape, np.nan) if u is None else np.atleast_2d(u)])
        self.count = len(self.values)
        self._check_draws()

    def add_u(self, u: np.ndarray) -> None:
        """Points at the standard normals ``u`` (rows), through the Nataf transform (none: a [random_field] varies
        alone)."""
        u = np.atleast_2d(u)
        self.add(self.sampler._values(u @ self.sampler.cholesky.T) if self.marginals else np.empty((len(u), 0)), u)

    def raw_of(self, i: int) -> dict:
        """The study dict of point ``i``; with its fields' ``combination`` where a Markov chain moved them
        (``field_terms``: subset simulation)."""
        case_raw = super().raw_of(i)
        terms = self.field_terms.get(i)
        if terms is not None:
            case_raw["random_field"]["combination"] = [[realisation, weight] for realisation, weight in terms]
        return case_raw

    def x_of(self, u: np.ndarray) -> np.ndarray:
        """The variables' values at the standard normals ``u``."""
        return self.sampler._values(np.atleast_2d(u) @ self.sampler.cholesky.T)[0]


@dataclass
class DesignPointOutcome(ProbabilisticOutcome):
    """What a form or point_estimate study found (module doc)."""

    method: str = ""
    n_searches: int = 0
    beta: float = math.nan  # form: the reliability index
    beta_fosm: float = math.nan  # form: the first iteration's, at the mean
    iterations: int = 0
    converged: bool = False
    stop_reason: str = ""
    design_point: dict = dataclasses.field(default_factory=dict)  # form: variable -> value at u*
    alpha: dict = dataclasses.field(default_factory=dict)  # form: variable -> sensitivity factor
    noisy: list = dataclasses.field(default_factory=list)  # form: variables whose step was within the noise
    discretised: tuple | None = None  # form: (low excess, high excess, beta at h -> 0 for each)
    pem_mean: float = math.nan
    pem_std: float = math.nan
    beta_normal: float = math.nan  # point_estimate: of a normal FOS
    beta_lognormal: float = math.nan

    @property
    def verdict(self) -> str:
        if self.method == "form":
            if not math.isfinite(self.beta):
                return f"FORM: no reliability index ({self.stop_reason})"
            return (f"FORM reliability index beta = {self.beta:.3f} (pf_FORM = Phi(-beta) = "
                    f"{form.failure_probability(self.beta):.3g}), " + ("converged" if self.converged else
                                                                         f"NOT converged: {self.stop_reason}")
                    + f" after {self.iterations} iterations; FOSM at the mean: beta = {self.beta_fosm:.3f}")
        return (f"point estimate (Rosenblueth, {self.n_searches} points at mean +- std; a screen, no tail): FOS mean "
                f"{self.pem_mean:.4g}, std {self.pem_std:.4g}; beta {self.beta_normal:.3f} (normal FOS), "
                f"{self.beta_lognormal:.3f} (lognormal FOS)")


class DesignPointStudy(ProbabilisticStudy):
    realisations: DesignPoints  # the points it places (ProbabilisticStudy's Realisations, placed not drawn)

    """A study with ``[probabilistic]`` and ``method = "form"`` or ``"point_estimate"`` (module doc)."""

    outcome_type = DesignPointOutcome

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.placement = dataclasses.replace(self.placement, rounds=True)
        self.iterations: list[form.Linearisation] = []
        self.noisy: set[int] = set()
        self.stop_reason = ""
        self.finished = False
        self.round_start = 0

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.probabilistic is not None and study.probabilistic.method in ("form", "point_estimate")

    def make_realisations(self) -> DesignPoints:
        points = DesignPoints(self.study)
        table = self.study.probabilistic
        if table.method == "form":
            points.add_u(form.gradient_points(np.zeros(len(points.marginals)), table.form_step))
        else:
            try:
                weights = point_estimate.weights(points.correlation)
            except ValueError as error:
                raise StudyError("probabilistic.correlation", str(error)) from None
            frozen = [marginal.frozen() for marginal in points.marginals]
            points.add(point_estimate.points(np.array([f.mean() for f in frozen]), np.array([f.std() for f in frozen])))
            self.weights = weights
        return points

    def cases(self) -> list[Case]:
        """The first round; case folders beyond the budget removed (those of later rounds of an earlier
        invocation are kept: the same points, read back)."""
        (self.out_dir / RESULT_NAME).unlink(missing_ok=True)
        make_output_folder(self.out_dir / CASES_FOLDER)
        points = self.realisations
        self.stale_cases = remove_stale_cases(self.out_dir / CASES_FOLDER,
                                              keep={points.case_id(i) for i in range(points.budget)})
        if self.shared_gravity:
            self.placement = dataclasses.replace(self.placement, gravity_in_process=True)
        from workflows.fos.prediction import Generations, WindowPredictor  # (as the base class: on use)

        self.generation_windows = (Generations(points.budget, LARGEST_GENERATION), WindowPredictor())
        self.batch_end = points.count
        return self.more_cases(FIRST_REALISATIONS)

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        super().case_concluded(case_id, outcome, progress)
        progress.tally(f"{self.n_concluded} FOS searches" + (f", iteration {len(self.iterations) + 1}"
                                                             if self.study.probabilistic.method == "form" else ""))

    def _fos_of_round(self, outcomes: dict) -> tuple[np.ndarray, np.ndarray]:
        """The FOS of each point of the round and its bracket width (NaN where none was found)."""
        points = self.realisations
        fos, brackets = [], []
        for i in range(self.round_start, points.count):
            outcome = outcomes[points.case_id(i)]
            result = diverged_result("", 0) if outcome.diverged else case_result(outcome.result)
            fos.append(result.fos)
            brackets.append(result.fos_high - result.fos_low)
        return np.array(fos, float), np.array(brackets, float)

    def next_cases(self, outcomes: dict, progress) -> list:
        """FORM's next iteration, once the last one's points are searched (module doc); none when beta has
        converged, a point has no FOS, or the budget is spent."""
        table = self.study.probabilistic
        if table.method != "form" or self.finished:
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

    def check_every_case(self) -> None:
        """The first round's points (later ones depend on its FOS values)."""
        for i in range(len(self.first), self.realisations.count):
            self.realisations.study_of(i, text=False)

    def conclude(self, outcomes: dict, timings, wall_start: float) -> DesignPointOutcome:
        import xarray as xr  # (as the base class's results: on use)

        from workflows.output.variables import PROBABILISTIC_FILE

        base = super().conclude(outcomes, timings, wall_start)
        for path in base.figures:  # a sample's figures: the points are none
            path.unlink(missing_ok=True)
        table = self.study.probabilistic
        points = self.realisations
        result = self.outcome_type(**{f.name: getattr(base, f.name) for f in dataclasses.fields(ProbabilisticOutcome)},
                                   method=table.method, n_searches=points.count)
        result.pf = result.pf_low = result.pf_high = math.nan
        result.figures = []
        var = PROBABILISTIC_FILE
        ds = xr.load_dataset(base.result_path)
        ds = ds.assign_coords(random_variable=("random_variable", np.array(points.labels, dtype=object),
                                               {"long_name": "random variable"}))
        attrs = {"pf": math.nan, "pf_low": math.nan, "pf_high": math.nan, "n_fos_searches": points.count,
                 "n_srf_runs": result.runs_made}
        ds["pf_running"] = var["pf_running"](np.full(ds.sizes["realisation"], math.nan))
        ds = ds.drop_vars("fos_rank_correlation", errors="ignore")  # a sample's statistics: the points are none
        attrs.update(fos_mean=math.nan, fos_std=math.nan, reliability_index_normal=math.nan,
                     reliability_index_lognormal=math.nan)
        result.fos_mean = result.fos_std = math.nan
        ds = self._method_results(result, ds, attrs)
        ds.attrs.update(attrs)
        write_dataset(ds, result.result_path)
        if self.study.output.figures:
            from workflows.probabilistic.design_point_figures import draw  # matplotlib: on use

            result.figures = [draw(self.out_dir, ds, table.method, table.factor)]
        self.stale_figures = remove_stale_figures(self.out_dir, FIGURES, keep={path.name for path in result.figures})
        return result

    def _method_results(self, result: DesignPointOutcome, ds, attrs: dict):
        """The method's own results into ``result``, the dataset ``ds`` (returned) and its ``attrs``."""
        from workflows.output.variables import PROBABILISTIC_FILE as var

        table = self.study.probabilistic
        points = self.realisations
        if table.method == "form":
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
        else:
            fos = ds["fos"].values
            result.pem_mean, result.pem_std = point_estimate.moments(fos, self.weights)
            result.beta_normal, result.beta_lognormal = point_estimate.reliability_indices(
                result.pem_mean, result.pem_std, table.factor)
            ds["point_weight"] = var["point_weight"](self.weights)
            result.fos_mean, result.fos_std = result.pem_mean, result.pem_std
            attrs.update(point_estimate_fos_mean=result.pem_mean, point_estimate_fos_std=result.pem_std,
                         reliability_index_normal=result.beta_normal,
                         reliability_index_lognormal=result.beta_lognormal)
        return ds

    def _form_result(self, result: DesignPointOutcome) -> None:
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

    def report(self, outcome: DesignPointOutcome, quiet: bool, study_file) -> Report:  # type: ignore[override]
        if quiet:
            return Report([outcome.verdict])
        lines = [outcome.verdict]
        if outcome.method == "form" and outcome.design_point:
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
        lines.append(f"{outcome.n_searches} FOS searches (each to fos_tolerance {self.study.probabilistic.fos_tolerance:g}), "
                     f"{outcome.runs_made} SRF runs made, wall time {outcome.timings_s['total']:.1f} s")
        lines.append(f"wrote {outcome.result_path}, {self.out_dir / CASES_FOLDER}/"
                     + "".join(f", {path.name}" for path in outcome.figures))
        return Report(lines + list(self.removed))

