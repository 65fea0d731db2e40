"""A parameter study: a study with ``[sweep]`` runs once per case, and ``OUT/study.nc`` brings them together.

1. The cases (:func:`workflows.study.reading.sweep_cases`) are checked before anything runs: a
   strength-reduction case's resolution, the memory of the largest.  Strength-reduction cases that
   would compute the same thing (equal ``fos.keys.case_key``, e.g. a swept field no stage uses) are
   computed once.
2. Each case to compute gets ``OUT/cases/<case>/`` with its study text ``case.toml``; its files are
   kept there exactly as a single study keeps them (reused by the next invocation while their keys
   hold).  Strength-reduction cases all run on one cluster (``workflows.cases``: gravity as tasks,
   no barrier between cases, each ``summary.nc`` as soon as its search is done, no figures); other
   cases run their stages in this process one after another.  A case that diverges is recorded
   and the sweep goes on.
3. ``OUT/study.nc`` and the design charts are written last (``sweep.results``, ``sweep.figures``):
   a sweep that stopped early leaves no ``study.nc`` (the one of an earlier invocation is removed
   at the start), and the same command resumes it.
4. What an earlier invocation made and this one does not is removed (``sweep.stale``): the case
   folders of cases the sweep no longer has and ``threshold.nc`` (drawn from ``study.nc``), at the start,
   and the design charts it did not draw, at the end; the report says so in one line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.cases import Case, CaseFeed, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.fos.discretisation import note
from workflows.fos_time.threshold import applies as threshold_applies
from workflows.fos_time.threshold import write_threshold
from workflows.memory_guard import check_memory, estimated_particles
from workflows.output.figures import remove_stale_figures
from workflows.output.stage_file import result_paths
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, case_error, sweep_cases
from workflows.sweep.figures import draw_runout_sweep, draw_sweep_figures
from workflows.sweep.report import stage_table_lines, table_lines
from workflows.sweep.results import (
    CASE_TEXT_NAME,
    CASES_FOLDER,
    COLLAPSE_SCALARS,
    DIVERGED_CASE,
    DONE,
    RUNOUT_SCALARS,
    STUDY_FILE_NAME,
    CaseResult,
    StageCaseResult,
    case_result,
    diverged_result,
    runout_stage_names,
    stage_sweep_dataset,
    study_dataset,
)
from workflows.sweep.stale import SWEEP_FIGURE_NAMES, remove_stale_cases, remove_stale_results, removed_line


@dataclass
class SweepOutcome:
    """What a sweep of a strength-reduction study did and found."""

    out_dir: Path
    study_path: Path  # OUT/study.nc
    cases: list[SweepCase]
    results: dict[str, CaseResult]  # by case id
    n_distinct: int
    runs_made: int  # SRF runs computed by this invocation
    runs_reused: int  # SRF runs read back from an earlier invocation
    gravity_computed: int  # gravity states relaxed by this invocation (cases sharing a gravity key share one)
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


@dataclass
class StageSweepOutcome:
    """What a sweep of a stage study did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    results: dict[str, StageCaseResult]  # by case id
    runout_stages: list[str]
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class SweepStudy(StudyType):
    """A study with ``[sweep]`` (module doc)."""

    placement = Placement(gravity_in_process=False, figures=False, quiet_cases=True, keep_going=True)
    label = "a sweep"
    base_note = "; the base study, before the sweep sets its values"
    stale_cases: tuple[list[str], list[str]] = ([], [])  # case folders of an earlier invocation: (removed, kept)
    stale_figures: list[str] = []  # design charts of an earlier invocation removed
    earlier_results: list[str] = []  # its threshold.nc, removed at the start
    stale_results: list[str] = []  # of those, the ones not written again

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.sweep is not None

    @property
    def fos(self) -> bool:
        return self.study.strength_reduction is not None

    def make_cases(self) -> list[SweepCase]:
        """The cases, each its own checked study (StudyError naming what fails)."""
        return sweep_cases(self.study)

    def check(self, options: RunOptions) -> None:
        """Each strength-reduction case's resolution; the memory of the largest case; the scene and
        simulation of one case per distinct gravity state (what they refuse, a material region that holds
        no particle, must be refused before the case folders are written), and with a ``[random_field]``
        of each case whose fields draw on other particles or scales (their embeddings; StudyError)."""
        from workflows.fos.keys import gravity_key  # the core (numba): once the study is known to be valid
        from workflows.scene import build_scene
        from workflows.stages.running import new_simulation

        self.sweep_cases = self.make_cases()
        if self.fos:
            for case in self.sweep_cases:
                try:
                    case.study.strength_reduction.check_resolution(case.study)
                except StudyError as error:
                    raise case_error(case.case_id, error) from None
        largest = max(self.sweep_cases, key=lambda case: estimated_particles(case.study))
        check_memory(largest.study, processes=self.processes(options), limit_bytes=options.max_memory_bytes)
        checked = set()
        for case in self.sweep_cases:
            fields = case.study.random_field
            key = (gravity_key(case.study), None if fields is None else fields.embeddings_key(case.study))
            if key not in checked:
                checked.add(key)
                try:
                    new_simulation(case.study, build_scene(case.study))
                except StudyError as error:
                    raise case_error(case.case_id, error) from None

    def processes(self, options: RunOptions) -> int:
        """Each local worker of a strength-reduction sweep (its cases' gravity runs as tasks); one
        process for a sweep of stages."""
        return (options.workers if not options.scheduler else 1) if self.fos else 1

    def cases(self) -> list[Case]:
        """A folder and ``case.toml`` per case to compute (module doc, steps 1-2); ``study.nc`` of an
        earlier invocation removed, and its threshold.nc."""
        make_output_folder(self.out_dir / CASES_FOLDER)
        (self.out_dir / STUDY_FILE_NAME).unlink(missing_ok=True)  # a stopped sweep must not show an old one
        self.earlier_results = remove_stale_results(self.out_dir, keep=set())  # nor a result drawn from it
        self.same_as = {case.case_id: case.case_id for case in self.sweep_cases}  # case id -> whose files it has
        distinct = self.sweep_cases
        if self.fos:
            from workflows.fos.keys import case_key  # (hashes the core's sources: not for the study reader)

            first_of: dict[str, SweepCase] = {}
            for case in self.sweep_cases:
                self.same_as[case.case_id] = first_of.setdefault(case_key(case.study), case).case_id
            distinct = list(first_of.values())
        self.stale_cases = remove_stale_cases(self.out_dir / CASES_FOLDER, keep={case.case_id for case in distinct})
        cases = []
        for case in distinct:
            folder = self.out_dir / CASES_FOLDER / case.case_id
            make_output_folder(folder)
            write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
            cases.append(Case(case.study, folder, case.case_id, case.position, case.values))
        if not self.fos:
            return cases
        from workflows.fos.prediction import PredictedFeed  # (scipy, the critical circle: once cases run)

        self.predicted = PredictedFeed(cases, [case_features(self.study, case.values) for case in cases])
        return self.predicted.more(len(cases))

    def feed(self) -> CaseFeed | None:
        """A strength-reduction sweep's cases after the first, generation by generation, each searched in
        a window about its predicted FOS (``fos.prediction.PredictedFeed``)."""
        if not self.fos:
            return None
        return CaseFeed(self.predicted.more, self.predicted.to_come)

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        """A strength-reduction case's FOS joins the prediction of the cases to come."""
        if self.fos:
            self.predicted.concluded(case_id, outcome.fos)

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float):
        """``OUT/study.nc`` and the design charts from the cases' outcomes (module doc, step 3)."""
        if self.fos:
            return self._conclude_fos(outcomes, timings, wall_start)
        return self._conclude_stages(outcomes, wall_start)

    def _conclude_fos(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> SweepOutcome:
        results = {}
        for case_id, outcome in outcomes.items():
            if outcome.diverged:
                results[case_id] = diverged_result(f"the gravity stage diverged: {outcome.error}", 0)
            else:
                results[case_id] = case_result(outcome.result)
        by_id = {case_id: results[original] for case_id, original in self.same_as.items()}
        study_path = self.out_dir / STUDY_FILE_NAME
        dataset = study_dataset(self.study, self.sweep_cases, by_id, self.same_as, len(outcomes))
        write_dataset(dataset, study_path)
        figures, result_files = [], []
        if self.study.output.figures:
            figures = draw_sweep_figures(self.out_dir, dataset)
        if threshold_applies(self.study):  # rain or drawdown over time: the duration at which the FOS reaches 1
            written = write_threshold(self.study, dataset, self.out_dir)
            figures += [path for path in written if path.suffix == ".png"]
            result_files = [path for path in written if path.suffix == ".nc"]
        self._remove_stale_outputs(figures, result_files)
        runs = [record for outcome in outcomes.values() for record in outcome.runs]
        runs_made = sum(record.started_s == record.started_s for record in runs)  # NaN: reused
        gravity_computed = sum(outcome.result.timings_s["gravity"] > 0.0 for outcome in outcomes.values()
                               if not outcome.diverged)
        timings_s = {"cases_elapsed": timings.cases_elapsed, "gravity_worker": timings.gravity_worker,
                     "srf_runs_worker": timings.srf_runs_worker, "total": time.perf_counter() - wall_start}
        return SweepOutcome(self.out_dir, study_path, self.sweep_cases, by_id, len(outcomes), runs_made,
                            len(runs) - runs_made, gravity_computed, timings_s, figures)

    def _conclude_stages(self, outcomes: dict, wall_start: float) -> StageSweepOutcome:
        results = {}
        for case in self.sweep_cases:
            outcome = outcomes[case.case_id]
            if outcome.diverged:
                results[case.case_id] = StageCaseResult(DIVERGED_CASE, str(outcome.error), 0, {}, {}, True)
            else:
                results[case.case_id] = _read_case(case.study, self.out_dir / CASES_FOLDER / case.case_id,
                                                   ran=not outcome.result.up_to_date)
        study_path = self.out_dir / STUDY_FILE_NAME
        dataset = stage_sweep_dataset(self.study, self.sweep_cases, results)
        write_dataset(dataset, study_path)
        figures = []
        if self.study.output.figures and runout_stage_names(self.study):
            figures = draw_runout_sweep(self.out_dir, dataset)
        self._remove_stale_outputs(figures, [])
        return StageSweepOutcome(self.out_dir, study_path, self.sweep_cases, results, runout_stage_names(self.study),
                                 {"total": time.perf_counter() - wall_start}, figures)

    def _remove_stale_outputs(self, drawn: list[Path], written: list[Path]) -> None:
        """The design charts and threshold.nc of an earlier invocation not made now removed (module doc, step 4)."""
        self.stale_figures = remove_stale_figures(self.out_dir, SWEEP_FIGURE_NAMES, keep={path.name for path in drawn})
        self.stale_results = [name for name in self.earlier_results if name not in {path.name for path in written}]

    @property
    def removed(self) -> list[str]:
        """The line saying what was removed (module doc, step 4), or none."""
        line = removed_line(*self.stale_cases, self.stale_figures, self.stale_results)
        return [line] if line else []

    def report(self, outcome, quiet: bool, study_file) -> Report:
        wrote = (f"wrote {outcome.study_path}, {outcome.out_dir / CASES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        if not self.fos:
            warnings = [f"warning: case {case.case_id}: {outcome.results[case.case_id].message}"
                        for case in outcome.cases if outcome.results[case.case_id].message]
            ran = sum(result.ran for result in outcome.results.values())
            header = (f"{self.study.name}: {len(outcome.cases)} cases, {ran} run, {len(outcome.cases) - ran} up to "
                      f"date, wall time {outcome.timings_s['total']:.1f} s")
            table = stage_table_lines(outcome)
            return Report(table if quiet else [header, *table, wrote, *self.removed], warnings)
        table = table_lines(outcome.cases, outcome.results)
        if quiet:
            return Report(table)
        reused = f", {outcome.runs_reused} reused" if outcome.runs_reused else ""
        same = (f" ({len(outcome.cases) - outcome.n_distinct} identical to another)"
                if outcome.n_distinct < len(outcome.cases) else "")
        header = (f"{self.study.name}: {len(outcome.cases)} cases{same}, {outcome.runs_made} SRF runs{reused}, "
                  f"wall time {outcome.timings_s['total']:.1f} s")

        return Report([header, *table, note(self.study, "each case's FOS"), wrote, *self.removed])


def case_features(study: Study, values: dict) -> list[float]:
    """A case's numbers for the prediction of its FOS (``fos.prediction``): each axis's value, a friction
    angle as its tangent (the FOS is close to linear in c and tan(phi)), a value that is no number as
    its position among the axis's values."""
    import math

    features = []
    for axis, value in zip(study.sweep.axes, values.values()):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            listed = list(axis.values) if axis.values is not None else []
            features.append(float(listed.index(value)) if value in listed else 0.0)
        elif axis.path.endswith("friction_deg") or axis.path.endswith("dilation_deg"):
            features.append(math.tan(math.radians(float(value))))
        else:
            features.append(float(value))
    return features


def _read_case(study: Study, folder: Path, ran: bool) -> StageCaseResult:
    """The metrics of a finished stage case from its stage files."""
    paths = dict(zip((stage.name for stage in study.stages), result_paths(study, folder)))
    runout = {}
    for name in runout_stage_names(study):
        with xr.open_dataset(paths[name]) as ds:
            runout[name] = {key: float(ds[key]) for key in RUNOUT_SCALARS}
    with xr.open_dataset(paths[study.stages[-1].name]) as last:
        n_particles = int(last.sizes.get("particle", 0))
        collapse = ({key: float(last[key]) if key in last else np.nan for key in COLLAPSE_SCALARS}
                    if study.metrics is not None else {})
    return StageCaseResult(DONE, "", n_particles, runout, collapse, ran)
