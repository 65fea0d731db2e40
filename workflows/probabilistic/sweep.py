"""A sweep of probabilistic studies: a study with ``[sweep]`` and ``[probabilistic]`` (pf against a
COV, a scale of fluctuation, a mean).

1. Each case of the sweep (``workflows.study.reading.sweep_cases``) is a probabilistic study of its
   own (``workflows.probabilistic.study_type.ProbabilisticStudy``) in ``OUT/cases/<case>/``: its
   study text ``case.toml`` (a probabilistic study that runs alone and reuses the sweep's
   realisations), its realisations under ``cases/``, its ``probabilistic.nc``.
2. The realisations of every case are tasks on one cluster, all in one round (each made as the
   case runner has room for it, case after case), or with ``pf_interval_width`` in each case's
   batches (realisations of random strengths share one gravity state across the cases too).
3. ``OUT/study.nc`` (``workflows.output.variables.PROBABILISTIC_SWEEP_FILE``: pf with its interval
   per case) and ``pf.png`` (pf against the first axis) are written last.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.cases import Case, CaseFeed, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.output.stage_file import provenance
from workflows.output.variables import PROBABILISTIC_SWEEP_FILE
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.probabilistic.study_type import ProbabilisticOutcome, ProbabilisticStudy
from workflows.progress import CaseProgress, Progress
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, sweep_cases
from workflows.sweep.report import fixed_width_table, value_text
from workflows.sweep.results import CASE_TEXT_NAME, CASES_FOLDER, STUDY_FILE_NAME, sweep_coordinates

SEPARATOR = " / "
"""A realisation's case id in the sweep: ``<sweep case id> / realisation_<i>``."""


@dataclass
class ProbabilisticSweepOutcome:
    """What a sweep of probabilistic studies did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    outcomes: dict[str, ProbabilisticOutcome]  # by sweep case id
    runs_made: int
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class ProbabilisticSweepStudy(StudyType):
    """A study with ``[sweep]`` and ``[probabilistic]`` (module doc)."""

    placement = Placement(gravity_in_process=False, figures=False, quiet_cases=True, keep_going=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.sweep is not None and study.probabilistic is not None

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.sweep_cases = sweep_cases(study)
        self.studies = {case.case_id: ProbabilisticStudy(case.study, out_dir / CASES_FOLDER / case.case_id)
                        for case in self.sweep_cases}
        if study.probabilistic.compute == "verdict":  # one run per realisation: its run file is its summary
            self.placement = dataclasses.replace(self.placement, summaries=False)
        if study.probabilistic.pf_interval_width is not None:  # each case in batches (ProbabilisticStudy)
            self.placement = dataclasses.replace(self.placement, rounds=True)

    def check(self, options: RunOptions) -> None:
        """Each case's own checks (``ProbabilisticStudy.check``), StudyError naming the case."""
        for case_id, study in self.studies.items():
            try:
                study.check(options)
            except StudyError as error:
                raise StudyError("sweep", f"the case {case_id.replace('__', ', ')}: {error}") from None

    def check_every_case(self) -> None:
        """Every realisation of every case made (``ProbabilisticStudy.check_every_case``)."""
        for case_id, study in self.studies.items():
            try:
                study.check_every_case()
            except StudyError as error:
                raise StudyError("sweep", f"the case {case_id.replace('__', ', ')}: {error}") from None

    def processes(self, options: RunOptions) -> int:
        return max(study.processes(options) for study in self.studies.values())

    def cases(self) -> list[Case]:
        """The first realisations of every case (``study.nc`` of an earlier invocation removed)."""
        make_output_folder(self.out_dir / CASES_FOLDER)
        (self.out_dir / STUDY_FILE_NAME).unlink(missing_ok=True)
        cases = []
        for case in self.sweep_cases:
            folder = self.out_dir / CASES_FOLDER / case.case_id
            make_output_folder(folder)
            write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
            cases += [dataclasses.replace(each, case_id=f"{case.case_id}{SEPARATOR}{each.case_id}")
                      for each in self.studies[case.case_id].cases()]
        return cases

    def feed(self) -> CaseFeed:
        """The realisations to come of every case, case after case."""
        feeds = [(sweep_id, study.feed()) for sweep_id, study in self.studies.items()]

        def more(count: int) -> list[Case]:
            made: list[Case] = []
            for sweep_id, feed in feeds:
                if len(made) >= count:
                    break
                made += [dataclasses.replace(each, case_id=f"{sweep_id}{SEPARATOR}{each.case_id}")
                         for each in feed.more(count - len(made))]
            return made

        return CaseFeed(more, lambda: sum(feed.to_come() for _, feed in feeds))

    def next_cases(self, outcomes: dict, progress: Progress) -> list[Case]:
        """Each case's next batch while its pf interval is too wide (``pf_interval_width``)."""
        more = []
        for sweep_id, study in self.studies.items():
            prefix = f"{sweep_id}{SEPARATOR}"
            own = {case_id[len(prefix):]: outcome for case_id, outcome in outcomes.items() if case_id.startswith(prefix)}
            more += [dataclasses.replace(each, case_id=prefix + each.case_id)
                     for each in study.next_cases(own, CaseProgress(progress, sweep_id))]
        return more

    def case_concluded(self, case_id: str, outcome, progress: Progress) -> None:
        sweep_id, own_id = case_id.split(SEPARATOR, 1)
        self.studies[sweep_id].case_concluded(own_id, outcome, CaseProgress(progress, sweep_id))

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> ProbabilisticSweepOutcome:
        own: dict[str, dict] = {case_id: {} for case_id in self.studies}
        for case_id, outcome in outcomes.items():
            sweep_id, own_id = case_id.split(SEPARATOR, 1)
            own[sweep_id][own_id] = outcome
        results = {case_id: study.conclude(own[case_id], CaseTimings(), wall_start)
                   for case_id, study in self.studies.items()}
        dims, shape, coords = sweep_coordinates(self.study, self.sweep_cases)
        columns = {name: np.full(shape, np.nan) for name in ("pf", "pf_low", "pf_high", "fos_mean", "fos_std")}
        columns |= {"n_failed": np.zeros(shape, np.int64), "n_decided": np.zeros(shape, np.int64),
                    "case_folder": np.full(shape, "", dtype=object)}
        for case in self.sweep_cases:
            result, at = results[case.case_id], case.position
            for name in ("pf", "pf_low", "pf_high", "fos_mean", "fos_std", "n_failed"):
                columns[name][at] = getattr(result, name)
            columns["n_decided"][at] = result.n_realisations - result.n_undecided
            columns["case_folder"][at] = case.case_id


        dataset = xr.Dataset(coords=coords)
        for name, values in columns.items():
            dataset[name] = PROBABILISTIC_SWEEP_FILE[name].over(dims, values)
        dataset.attrs = {"title": f"spfem-fos sweep of the probabilistic study {self.study.name}: pf of every case",
                         "Conventions": "CF-1.11", "study_name": self.study.name,
                         "sweep_combination": self.study.sweep.combination,
                         "sweep_axes": ", ".join(axis.path for axis in self.study.sweep.axes),
                         "n_cases": len(self.sweep_cases), **provenance(self.study)}
        study_path = self.out_dir / STUDY_FILE_NAME
        write_dataset(dataset, study_path)
        figures = []
        if self.study.output.figures:
            from workflows.probabilistic.figures import draw_pf_sweep  # matplotlib only when drawing

            figures = [draw_pf_sweep(self.out_dir, dataset)]
        timings_s = {"cases_elapsed": timings.cases_elapsed, "srf_runs_worker": timings.srf_runs_worker,
                     "total": time.perf_counter() - wall_start}
        return ProbabilisticSweepOutcome(self.out_dir, study_path, self.sweep_cases, results,
                                         sum(result.runs_made for result in results.values()), timings_s, figures)

    def report(self, outcome: ProbabilisticSweepOutcome, quiet: bool, study_file) -> Report:
        labels = list(outcome.cases[0].values)
        rows = []
        for case in outcome.cases:
            result = outcome.outcomes[case.case_id]
            rows.append([value_text(case.values[label]) for label in labels]
                        + [f"{result.pf:.4g} [{result.pf_low:.4g}, {result.pf_high:.4g}]",
                           f"{result.n_failed} / {result.n_realisations - result.n_undecided}"])
        table = fixed_width_table(labels + ["pf [95% interval]", "failed"], rows, len(labels))
        if quiet:
            return Report(table)
        header = (f"{self.study.name}: {len(outcome.cases)} probabilistic cases, {outcome.runs_made} SRF runs, "
                  f"wall time {outcome.timings_s['total']:.1f} s")
        wrote = (f"wrote {outcome.study_path}, {outcome.out_dir / CASES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        return Report([header, *table, wrote])

