"""A sweep of studies of another type: the rule by which ``[sweep]`` composes with the study types.

A study with ``[sweep]`` whose cases are studies of a type that makes cases of its own (a
refinement study, a probabilistic study: ``workflows.study_types``) is a :class:`NestedSweep` of
that type:

1. each case of the sweep (``workflows.study.reading.sweep_cases``) is a study of the inner type in
   ``OUT/cases/<case>/`` with its study text ``case.toml``, exactly as the study alone would be
   (its own checks, cases, folders and result file, reused by the next invocation while their keys
   hold);
2. every case's cases run together on one cluster, each under the id ``<sweep case> / <its id>``
   (gravity as tasks, the cases' messages quiet): the first cases of every inner study, those each
   feeds as the case runner has room, then round after round each inner study's next cases from the
   outcomes of its own (only the inner studies whose cases concluded in the round are asked);
3. a case that diverges goes to its inner study where that type keeps going; where it stops a study
   of that type (a refinement study), it ends that sweep case alone, recorded as diverged with a
   warning, and the sweep goes on;
4. each inner study concludes on its own cases, and what a sweep of that type writes (``OUT/study.nc``,
   its figures and the table it prints: a :class:`SweepSummary` of ``study_types.SWEPT``) brings
   them together.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from workflows.cases import Case, CaseFeed, CaseTimings, Concluded, Placement, Report, RunOptions, StudyType
from workflows.output.writing import make_output_folder, write_text_if_changed
from workflows.progress import CaseProgress, Progress
from workflows.study import Study, StudyError
from workflows.study.reading import sweep_cases
from workflows.sweep.results import CASE_TEXT_NAME, CASES_FOLDER, STUDY_FILE_NAME
from workflows.sweep.study_type import SweepStudy

SEPARATOR = " / "
"""A case's id in the sweep: ``<sweep case id> / <its id in its own study>``."""


class SweepSummary:
    """What a sweep of one study type writes and prints once every inner study has concluded."""

    label: str  # what the study is, for report.html: "a sweep of ... studies"

    def conclude(self, sweep: NestedSweep, concluded: dict, own: dict, timings: CaseTimings, wall_start: float):
        """The sweep's outcome (``OUT/study.nc``, figures) from ``concluded``: by sweep case id, the inner
        study's outcome as ``cases.Concluded``, or the ``cases.Diverged`` that ended a study of a type that
        stops on one; ``own``: by sweep case id, the outcomes of its own cases by their own ids."""
        raise NotImplementedError

    def report(self, sweep: NestedSweep, outcome, quiet: bool) -> Report:
        """What the command prints."""
        raise NotImplementedError


class NestedSweep(StudyType):
    """A study with ``[sweep]`` whose cases are studies of ``inner`` (module doc)."""

    def __init__(self, study: Study, out_dir: Path, inner: type[StudyType], summary: SweepSummary):
        super().__init__(study, out_dir)
        self.summary = summary
        self.sweep_cases = sweep_cases(study)
        self.studies = {case.case_id: inner(case.study, self.out_dir / CASES_FOLDER / case.case_id)
                        for case in self.sweep_cases}
        self.first = next(iter(self.studies.values()))
        self.issued: dict[str, str] = {}  # the sweep's id of a case computing -> its sweep case id
        self.stopped: dict = {}  # sweep case id -> the Diverged outcome that ended its study (module doc, step 3)

    @property
    def label(self) -> str:
        return self.summary.label

    @property
    def base_note(self) -> str:
        """The inner type's note, else a sweep's."""
        return self.first.base_note or SweepStudy.base_note

    @property
    def placement(self) -> Placement:
        """The inner type's rounds and summaries; gravity as tasks, no figure per case, the cases quiet, a
        diverged case recorded (module doc, steps 2-3)."""
        inner = self.first.placement
        return Placement(gravity_in_process=False, figures=False, quiet_cases=True, keep_going=True,
                         rounds=inner.rounds, summaries=inner.summaries)

    def _each(self, check) -> None:
        """``check`` of every inner study, StudyError naming the case."""
        for case_id, study in self.studies.items():
            try:
                check(study)
            except StudyError as error:
                raise StudyError("sweep", f"the case {case_id.replace('__', ', ')}: {error}") from None

    def check(self, options: RunOptions) -> None:
        """Each case's own checks (its type's ``check``)."""
        self._each(lambda study: study.check(options))

    def check_every_case(self) -> None:
        """Each case's own ``check_every_case``."""
        self._each(lambda study: study.check_every_case())

    def warnings(self) -> list[str]:
        """The first case's own warnings."""
        return self.first.warnings()

    def processes(self, options: RunOptions) -> int:
        return max(study.processes(options) for study in self.studies.values())

    def _issued(self, sweep_id: str, cases: list[Case]) -> list[Case]:
        """``cases`` of the inner study of ``sweep_id`` under their ids in the sweep."""
        issued = [dataclasses.replace(case, case_id=f"{sweep_id}{SEPARATOR}{case.case_id}") for case in cases]
        self.issued.update((case.case_id, sweep_id) for case in issued)
        return issued

    def cases(self) -> list[Case]:
        """Each case's folder and ``case.toml``, and the first cases of every inner study (``study.nc`` of an
        earlier invocation removed)."""
        make_output_folder(self.out_dir / CASES_FOLDER)
        (self.out_dir / STUDY_FILE_NAME).unlink(missing_ok=True)  # a stopped sweep must not show an old one
        cases = []
        for case in self.sweep_cases:
            folder = self.out_dir / CASES_FOLDER / case.case_id
            make_output_folder(folder)
            write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
            cases += self._issued(case.case_id, self.studies[case.case_id].cases())
        return cases

    def feed(self) -> CaseFeed | None:
        """The cases every inner study feeds, case after case (none where no inner study feeds)."""
        feeds = [(sweep_id, feed) for sweep_id, study in self.studies.items() if (feed := study.feed()) is not None]
        if not feeds:
            return None

        def more(count: int) -> list[Case]:
            made: list[Case] = []
            for sweep_id, feed in feeds:
                if len(made) >= count:
                    break
                made += self._issued(sweep_id, feed.more(count - len(made)))
            return made

        return CaseFeed(more, lambda: sum(feed.to_come() for _, feed in feeds))

    def _own(self, outcomes: dict) -> dict[str, dict]:
        """``outcomes`` by sweep case id, each by its id in its own study."""
        own: dict[str, dict] = {case_id: {} for case_id in self.studies}
        for case_id, outcome in outcomes.items():
            sweep_id, own_id = case_id.split(SEPARATOR, 1)
            own[sweep_id][own_id] = outcome
        return own

    def _goes_on(self, sweep_id: str, outcome, progress: Progress) -> bool:
        """Whether the inner study of ``sweep_id`` takes ``outcome``: not once a diverged case ended it
        (module doc, step 3)."""
        if sweep_id in self.stopped:
            return False
        if outcome.diverged and not self.studies[sweep_id].placement.keep_going:
            progress.message(f"warning: case {sweep_id.replace('__', ', ')}: the gravity stage diverged: "
                             f"{outcome.error}")
            self.stopped[sweep_id] = outcome
            return False
        return True

    def case_concluded(self, case_id: str, outcome, progress: Progress) -> None:
        sweep_id, own_id = case_id.split(SEPARATOR, 1)
        if not outcome.diverged or self.studies[sweep_id].placement.keep_going:
            self.studies[sweep_id].case_concluded(own_id, outcome, CaseProgress(progress, sweep_id))

    def next_cases(self, outcomes: dict, progress: Progress) -> list[Case]:
        """The next cases of each inner study whose cases concluded in the round just done (module doc,
        step 2), from the outcomes of its own cases so far."""
        done = [case_id for case_id in self.issued if case_id in outcomes]
        asked = []
        for case_id in done:
            sweep_id = self.issued.pop(case_id)
            if self._goes_on(sweep_id, outcomes[case_id], progress) and sweep_id not in asked:
                asked.append(sweep_id)
        own = self._own(outcomes)
        more = []
        for sweep_id in asked:
            if sweep_id not in self.stopped:
                more += self._issued(sweep_id, self.studies[sweep_id].next_cases(own[sweep_id],
                                                                               CaseProgress(progress, sweep_id)))
        return more

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float):
        """Each inner study concluded on its own cases (or the divergence that ended it), then the sweep's
        summary (module doc, step 4)."""
        own = self._own(outcomes)
        concluded = {sweep_id: self.stopped.get(sweep_id) or Concluded(study.conclude(own[sweep_id], CaseTimings(),
                                                                                   wall_start))
                     for sweep_id, study in self.studies.items()}
        return self.summary.conclude(self, concluded, own, timings, wall_start)

    def report(self, outcome, quiet: bool, study_file) -> Report:
        return self.summary.report(self, outcome, quiet)
