"""A probabilistic study whose points are placed, not sampled, for random variables, each point's FOS by
its search: what FORM (``form_study``), the point estimate (``point_estimate_study``) and subset
simulation (``subset_study``) share.  Points are realisations of the study in
``OUT/cases/realisation_<i>/`` (round after round), each a study with its values in the unit of their
paths, from ``u`` by the Nataf transform of ``workflows.probabilistic.sampling``.

Every search is to ``fos_tolerance`` (the stage's, set tighter: FORM's differences must stand above the
FOS's own noise, the search's bracket), from an ``srf_min`` of at most half the factor to an ``srf_max`` of at
least twice it (the design point lies at FOS = factor, perhaps outside the range a study of the mean soil
may give).  The points are a function of the FOS values before them
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
"""Each point's search starts at most at this share of the factor and ends at least at the factor over it
(FORM's design point has FOS = factor; subset simulation counts the FOS below the factor, and one above
``srf_max`` is only known to be above it: with a factor above ``srf_max`` such a point never counted)."""


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
        node, key, _ = resolve_sweep_path(self.raw, f"stages.{stage}.srf_max")  # (a FOS above it: only "above")
        node[key] = self.srf_top = max(study.strength_reduction.srf_max, study.probabilistic.factor / SRF_MIN_SHARE)

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
        self.srf_max: dict[int, float] = {}  # point -> the srf_max its search runs first (subset simulation's threshold)
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
        (``field_terms``), and its ``srf_max`` where its search runs its level's threshold first (``srf_max``:
        subset simulation)."""
        case_raw = super().raw_of(i)
        terms = self.field_terms.get(i)
        if terms is not None:
            case_raw["random_field"]["combination"] = [[realisation, weight] for realisation, weight in terms]
        if i in self.srf_max:  # (its step within the range it leaves: the stage's own check)
            node, key, _ = resolve_sweep_path(case_raw, f"stages.{self.study.strength_reduction.name}.srf_max")
            node[key] = self.srf_max[i]
            if self.study.strength_reduction.srf_step > self.srf_max[i] - node["srf_min"]:
                node["srf_step"] = round(self.srf_max[i] - node["srf_min"], 4)
        return case_raw

    def x_of(self, u: np.ndarray) -> np.ndarray:
        """The variables' values at the standard normals ``u``."""
        return self.sampler._values(np.atleast_2d(u) @ self.sampler.cholesky.T)[0]


@dataclass
class DesignPointOutcome(ProbabilisticOutcome):
    """What a study of placed points found (each method's outcome adds its own)."""

    method: str = ""
    n_searches: int = 0
    stop_reason: str = ""

    @property
    def verdict(self) -> str:
        raise NotImplementedError  # each method's outcome says it


class DesignPointStudy(ProbabilisticStudy):
    realisations: DesignPoints  # the points it places (ProbabilisticStudy's Realisations, placed not drawn)

    """A study whose points are placed (module doc): what FORM, the point estimate and subset simulation
    share; each is a subclass with its points, rounds, results and figure."""

    outcome_type = DesignPointOutcome

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.placement = dataclasses.replace(self.placement, rounds=True)
        self.stop_reason = ""
        self.finished = False
        self.round_start = 0

    def make_realisations(self) -> DesignPoints:
        """The first round's points (each method's)."""
        raise NotImplementedError

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
        self.batch_end = self.first_round_end()
        return self.more_cases(FIRST_REALISATIONS)

    def first_round_end(self) -> int:
        """How many of the points made so far the first round hands out (here all: each method's)."""
        return self.realisations.count

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        super().case_concluded(case_id, outcome, progress)
        progress.tally(f"{self.n_concluded} FOS searches{self._round_note()}")

    def _round_note(self) -> str:
        """What the tally adds of the round (FORM: its iteration)."""
        return ""

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
        """None: the points of one round (FORM's and subset simulation's rounds: their own)."""
        return []

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
            result.figures = [self._figure(ds)]
        self.stale_figures = remove_stale_figures(self.out_dir, FIGURES, keep={path.name for path in result.figures})
        return result

    def _method_results(self, result: DesignPointOutcome, ds, attrs: dict):
        """The method's own results into ``result``, the dataset ``ds`` (returned) and its ``attrs``."""
        raise NotImplementedError

    def _figure(self, ds) -> Path:
        """The method's figure of ``probabilistic.nc`` (``design_point_figures``)."""
        raise NotImplementedError

    def _report_lines(self, outcome: DesignPointOutcome) -> list[str]:
        """What the method's report adds after its verdict."""
        return []

    def report(self, outcome: DesignPointOutcome, quiet: bool, study_file) -> Report:  # type: ignore[override]
        if quiet:
            return Report([outcome.verdict])
        lines = [outcome.verdict]
        lines += self._report_lines(outcome)
        lines.append(f"{outcome.n_searches} FOS searches (each to fos_tolerance {self.study.probabilistic.fos_tolerance:g}), "
                     f"{outcome.runs_made} SRF runs made, wall time {outcome.timings_s['total']:.1f} s")
        lines.append(f"wrote {outcome.result_path}, {self.out_dir / CASES_FOLDER}/"
                     + "".join(f", {path.name}" for path in outcome.figures))
        return Report(lines + list(self.removed))

