"""A sweep of refinement studies: a study with ``[sweep]`` and ``[refinement]`` refines every case.

1. Each case of the sweep (``workflows.study.reading.sweep_cases``) is a refinement study of its
   own (``workflows.refinement.study_type.RefinementStudy``) in ``OUT/cases/<case>/``: its study
   text ``case.toml`` (a refinement study that runs alone, and reuses the sweep's levels), its levels
   under ``levels/``, its ``refinement.nc`` and convergence figure, exactly as the study alone
   would write them (and reused by the next invocation while their keys hold).
2. The cases advance together, a level per round: the first level of every case, then each case's
   next level (or its current level in a grown window) as soon as the round is done, all on one
   cluster, gravity as tasks.  A case whose gravity diverges is recorded and the sweep goes on.
3. ``OUT/study.nc`` (the sweep's variables for each case's finest level, and the extrapolation:
   ``workflows.output.variables.REFINED_SWEEP_FILE``) and the design charts are written last.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from spfem_core.divergence import DivergenceError
from workflows.cases import Case, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.progress import CaseProgress, Progress
from workflows.refinement.results import refined_sweep_dataset
from workflows.refinement.study_type import RefinementOutcome, RefinementStudy
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, sweep_cases
from workflows.sweep.figures import draw_sweep_figures
from workflows.sweep.report import fixed_width_table, value_text
from workflows.sweep.results import (
    CASE_TEXT_NAME,
    CASES_FOLDER,
    STUDY_FILE_NAME,
    CaseResult,
    case_result,
    diverged_result,
)

LEVEL_SEPARATOR = " / "
"""A level's case id in the sweep: ``<sweep case id> / level k (h = ... m)``."""


@dataclass
class RefinedSweepOutcome:
    """What a sweep of refinement studies did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    refinements: dict[str, RefinementOutcome | None]  # by case id; None: its gravity diverged
    results: dict[str, CaseResult]  # the finest level of each case, by case id
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class RefinedSweepStudy(StudyType):
    """A study with ``[sweep]`` and ``[refinement]`` (module doc)."""

    placement = Placement(gravity_in_process=False, figures=False, quiet_cases=True, keep_going=True, rounds=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.sweep is not None and study.refinement is not None

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.sweep_cases = sweep_cases(study)
        self.refinements = {case.case_id: RefinementStudy(case.study, self.out_dir / CASES_FOLDER / case.case_id)
                            for case in self.sweep_cases}
        self.level_outcomes: dict[str, dict] = {case_id: {} for case_id in self.refinements}
        self.pending: dict[str, str] = {}  # the sweep's id of a level being computed -> its case id
        self.diverged: dict[str, DivergenceError] = {}

    def check(self, options: RunOptions) -> None:
        """Each case's own checks (its levels' resolution and the memory of its finest level:
        ``RefinementStudy.check``), StudyError naming the case."""
        for case_id, refinement in self.refinements.items():
            try:
                refinement.check(options)
            except StudyError as error:
                raise StudyError("sweep", f"the case {case_id.replace('__', ', ')}: {error}") from None

    def warnings(self) -> list[str]:
        """Thin layers at the finest level of the first case (``workflows.layers``)."""
        return next(iter(self.refinements.values())).warnings()

    def _sweep_case(self, case_id: str, case: Case) -> Case:
        sweep_case = next(each for each in self.sweep_cases if each.case_id == case_id)
        level_id = f"{case_id}{LEVEL_SEPARATOR}{case.case_id}"
        self.pending[level_id] = case_id
        return dataclasses.replace(case, case_id=level_id, position=sweep_case.position, values=sweep_case.values)

    def cases(self) -> list[Case]:
        """The first level of every case (``study.nc`` of an earlier invocation removed)."""
        make_output_folder(self.out_dir / CASES_FOLDER)
        (self.out_dir / STUDY_FILE_NAME).unlink(missing_ok=True)
        for case in self.sweep_cases:
            make_output_folder(self.out_dir / CASES_FOLDER / case.case_id)
            write_text_if_changed(self.out_dir / CASES_FOLDER / case.case_id / CASE_TEXT_NAME, case.study.source_text)
        return [self._sweep_case(case_id, case) for case_id, refinement in self.refinements.items()
                for case in refinement.cases()]

    def next_cases(self, outcomes: dict, progress: Progress) -> list[Case]:
        """Each case's next level, from the levels of the round just done (module doc, step 2)."""
        done = [level_id for level_id in self.pending if level_id in outcomes]
        more = []
        for level_id in done:
            case_id = self.pending.pop(level_id)
            outcome = outcomes[level_id]
            if isinstance(outcome, DivergenceError):
                progress.message(f"warning: case {case_id.replace('__', ', ')}: the gravity stage diverged: {outcome}")
                self.diverged[case_id] = outcome
                continue
            own_id = level_id.split(LEVEL_SEPARATOR, 1)[1]
            self.level_outcomes[case_id][own_id] = outcome
            next_levels = self.refinements[case_id].next_cases(self.level_outcomes[case_id],
                                                               CaseProgress(progress, case_id))
            more += [self._sweep_case(case_id, case) for case in next_levels]
        return more

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> RefinedSweepOutcome:
        refinements: dict[str, RefinementOutcome | None] = {}
        results = {}
        for case_id, refinement in self.refinements.items():
            if case_id in self.diverged:
                refinements[case_id] = None
                results[case_id] = diverged_result(f"the gravity stage diverged: {self.diverged[case_id]}", 0)
                continue
            refinements[case_id] = refinement.conclude(self.level_outcomes[case_id], CaseTimings(), wall_start)
            finest = self.level_outcomes[case_id][refinement._case_id(max(refinement.found))] \
                if refinement.found else next(iter(self.level_outcomes[case_id].values()))
            results[case_id] = case_result(finest)
        study_path = self.out_dir / STUDY_FILE_NAME
        dataset = refined_sweep_dataset(self.study, self.sweep_cases, results, refinements)
        write_dataset(dataset, study_path)
        figures = []
        if self.study.output.figures:
            figures = draw_sweep_figures(self.out_dir, dataset)
        timings_s = {"cases_elapsed": timings.cases_elapsed, "gravity_worker": timings.gravity_worker,
                     "srf_runs_worker": timings.srf_runs_worker, "total": time.perf_counter() - wall_start}
        return RefinedSweepOutcome(self.out_dir, study_path, self.sweep_cases, refinements, results, timings_s,
                                   figures)

    def report(self, outcome: RefinedSweepOutcome, quiet: bool, study_file) -> Report:
        labels = list(outcome.cases[0].values)
        rows = []
        for case in outcome.cases:
            refinement, finest = outcome.refinements[case.case_id], outcome.results[case.case_id]
            x = refinement.band if refinement is not None else None
            levels = " ".join(f"{level.fos:.4f}" if math.isfinite(level.fos) else "-"
                              for level in (refinement.levels if refinement is not None else []))
            band = f"{x.fos:.4f} +- {x.uncertainty:.4f}" if x is not None else "-"
            status = (("trusted" if x.trusted else "not trusted") if x is not None else
                      (refinement.message if refinement is not None else finest.status))
            rows.append([value_text(case.values[label]) for label in labels] + [levels, band, status])
        table = fixed_width_table(labels + ["FOS per level", "FOS at h -> 0 (95%)", "band"], rows, len(labels))
        if quiet:
            return Report(table)
        header = f"{self.study.name}: {len(outcome.cases)} cases refined, wall time {outcome.timings_s['total']:.1f} s"
        wrote = (f"wrote {outcome.study_path}, {outcome.out_dir / CASES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        return Report([header, *table, wrote])

