"""The case runner: the one place a study's cases are computed, whatever the study type.

A case is one study with its own output folder: the whole study of a single study, or one
combination of a sweep (``workflows.study_types``).  :func:`run_cases` computes a list of cases:

- cases with a ``strength_reduction`` stage on one dask cluster (local workers, or a scheduler's):
  the FOS engine (``workflows.fos.engine``) runs every case's gravity state and SRF search at once,
  and each case is concluded (``workflows.fos.summary.conclude_case``: its FOS, ``summary.nc``,
  figures when the type wants them) as soon as its search is done;
- other cases in this process, one after another, each on all cores
  (``workflows.stages.running.run_stages``): no cluster starts.

What a type decides is in :class:`Placement`: where a case's gravity runs (in this process while
the cluster starts, or as tasks), whether each case draws its own figures, which messages of a
case are shown, and whether a case that diverges stops the study or is recorded.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from spfem_core.divergence import DivergenceError
from workflows.layers import thin_layer_warnings
from workflows.output.figures import import_pyplot_in_background
from workflows.progress import OnlyWarnings, Progress
from workflows.study import Study, StudyError
from workflows.study.reading import case_error
from workflows.water.table import water_above_ground_warnings

if TYPE_CHECKING:
    from workflows.fos.task import RunPolicy  # (imports dask: only when FOS cases run)


@dataclass(frozen=True)
class Case:
    """One study to compute in its own folder."""

    study: Study  # its own study (no sweep); ``source_text`` its own TOML text
    out_dir: Path
    case_id: str = ""  # "" for a single study; a sweep's folder name under OUT/cases/
    position: tuple[int, ...] = ()  # index along each axis (grid), or (i,) the i-th case (zip)
    values: dict = field(default_factory=dict)  # axis label -> the value of this case
    gravity_dir: Path | None = None  # where its gravity files are read and written (default out_dir): cases
    # that share one gravity state may share one folder of it
    write_gravity: bool = True  # False: its gravity state is kept in memory only (recomputed if needed again)
    runs: RunPolicy | None = None  # what its SRF runs keep and when they end (default: every run kept whole)
    window: tuple[float, float, float] | None = None  # (low, high, step) its FOS search starts in (fos.prediction)
    top_first: bool = False  # its search runs srf_max first, alone: stable there ends it (``fos.search``, step 6)
    guard: float | None = None  # with top_first: the SRF run next where srf_max failed; stable there ends it (step 6)
    flow: object = None  # the flow its water comes from, when its type has it (``scene.water_flow``): not solved again


@dataclass(frozen=True)
class RunOptions:
    """How to run: the command line's options."""

    workers: int = 2  # local dask worker processes (strength reduction)
    scheduler: str | None = None  # a running dask scheduler instead of local workers
    force: bool = False  # run again what is up to date
    max_memory_bytes: float | None = None  # refuse what needs more (default: what the machine has available)


@dataclass(frozen=True)
class Placement:
    """What a study type decides about running its cases (module doc)."""

    gravity_in_process: bool  # a case's gravity on this process's cores while the cluster starts
    figures: bool  # each FOS case draws its own figures
    quiet_cases: bool  # a case's messages only when they are warnings
    keep_going: bool  # a case that diverges is recorded (its outcome: ``Diverged``)
    rounds: bool = False  # it makes cases in rounds (``StudyType.next_cases``): one cluster serves them all
    summaries: bool = True  # each FOS case writes its summary.nc (False: cases of one run each, summed up by the type)


@dataclass(frozen=True)
class CaseFeed:
    """Cases a type makes only when the case runner has room for them (the realisations of a
    probabilistic study: a study of 100,000 starts its first run as one of ten does)."""

    more: Callable[[int], list[Case]]  # up to this many more cases ([] with some left: none until more conclude)
    to_come: Callable[[], int]  # how many are left


@dataclass(frozen=True)
class Concluded:
    """The outcome of a case that ran to its end: its ``result``, a ``fos.summary.FosOutcome`` (a
    strength-reduction case) or a ``stages.running.StudyRun``."""

    result: Any
    diverged: ClassVar[bool] = False
    error: ClassVar[None] = None

    @property
    def fos(self) -> float:
        """A strength-reduction case's FOS (NaN where its search found none)."""
        return self.result.fos

    @property
    def runs(self) -> list:
        """A strength-reduction case's SRF runs (their ``RunRecord``)."""
        return self.result.runs


@dataclass(frozen=True)
class Diverged:
    """The outcome of a case whose simulation diverged (its gravity stage; a stage of a stage study),
    recorded where the placement keeps going: ``error``, the core's DivergenceError."""

    error: DivergenceError
    diverged: ClassVar[bool] = True
    result: ClassVar[None] = None
    fos: ClassVar[float] = float("nan")  # no FOS
    runs: ClassVar[tuple] = ()  # no SRF run


CaseOutcome = Concluded | Diverged
"""What a case came to (:func:`run_cases`): a study type reads ``diverged``, ``result`` and ``error``."""


@dataclass
class CaseTimings:
    """Where the wall time of :func:`run_cases` went (s)."""

    cases_elapsed: float = 0.0
    gravity_worker: float = 0.0  # summed over the cases that computed it
    srf_runs_worker: float = 0.0  # summed over the runs made now

    def add(self, other: CaseTimings) -> None:
        """Add the timings of another round of cases."""
        self.cases_elapsed += other.cases_elapsed
        self.gravity_worker += other.gravity_worker
        self.srf_runs_worker += other.srf_runs_worker


def run_cases(cases: list[Case], placement: Placement, options: RunOptions, progress: Progress,
              wall_start: float, session=None, on_case=None, feed: CaseFeed | None = None) -> tuple[dict, CaseTimings]:
    """Compute ``cases`` (module doc), and those of ``feed`` as there is room for them; (outcome by case
    id, timings).  An outcome is :class:`Concluded` (with a ``fos.summary.FosOutcome`` or a
    ``stages.running.StudyRun``), or :class:`Diverged` where the placement keeps going.  ``session``: a
    ``fos.cluster.DaskSession`` kept open by the caller for later rounds (default: one started and
    closed here); ``on_case``: called with (case id, outcome) as each FOS case concludes."""
    if cases[0].study.strength_reduction is not None:
        return _fos_cases(cases, placement, options, progress, wall_start, session, on_case, feed)
    if feed is not None:
        cases = cases + feed.more(feed.to_come())
    return _stage_cases(cases, placement, options, progress)


def _fos_cases(cases, placement: Placement, options: RunOptions, progress: Progress, wall_start: float,
               session=None, on_case=None, feed: CaseFeed | None = None):
    """Every case's gravity and SRF search on one cluster (``fos.engine``)."""
    from spfem_core.warmup import warm_up  # dask and the core: once the study is known to be valid
    from workflows.fos.case_search import CaseSearch
    from workflows.fos.cluster import dask_session
    from workflows.fos.dask_runs import DaskRuns
    from workflows.fos.engine import Engine
    from workflows.fos.summary import conclude_case
    from workflows.fos.task import RunPolicy

    start_unix_s = time.time()
    made = 0

    def searches_of(more: list[Case]) -> list[CaseSearch]:
        nonlocal made
        searches = [CaseSearch(made + k, case.study, case.out_dir, label=case.case_id,
                               gravity_here=placement.gravity_in_process, gravity_dir=case.gravity_dir or case.out_dir,
                               write_gravity=case.write_gravity, policy=case.runs or RunPolicy(),
                               window=case.window, top_first=case.top_first, guard=case.guard, flow=case.flow)
                    for k, case in enumerate(more)]
        made += len(more)
        return searches

    more = None if feed is None else (lambda count: searches_of(feed.more(count)))
    case_progress = OnlyWarnings(progress) if placement.quiet_cases else progress
    outcomes, timings = {}, CaseTimings()
    own = session is None
    with (dask_session(options.workers, options.scheduler, warm_up_worker=placement.gravity_in_process) if own
          else nullcontext(session)) as session:
        if not placement.gravity_in_process:
            warm_up()  # the compiled loop in the disk cache before the first task: compiled once
        engine_start = time.perf_counter()
        if placement.figures:
            import_pyplot_in_background()
        engine = Engine(DaskRuns(session), searches_of(cases), progress, start_unix_s, force=options.force, more=more,
                        to_come=None if feed is None else feed.to_come)
        for search in engine.run():
            if own and engine.all_concluded:
                session.close(wait=False)  # the workers shut down while the last summary and figures are made
            outcomes[search.label] = (Diverged(search.error) if search.error is not None else
                                      Concluded(conclude_case(search, case_progress, wall_start,
                                                              figures=placement.figures,
                                                              summary_file=placement.summaries)))
            timings.gravity_worker += search.gravity_wall_s
            timings.srf_runs_worker += sum(record.wall_time_s for record in search.runs.values()
                                           if record.started_s == record.started_s)  # NaN: reused
            if on_case is not None:
                on_case(search.label, outcomes[search.label])
        timings.cases_elapsed = time.perf_counter() - engine_start
    return outcomes, timings


def _stage_cases(cases, placement: Placement, options: RunOptions, progress: Progress):
    """Every case's stages in this process, one case after another."""
    from workflows.stages.running import run_stages  # the core: once the study is known to be valid

    outcomes: dict[str, object] = {}  # a StudyRun, or the DivergenceError of a case that diverged
    timings = CaseTimings()
    start = time.perf_counter()
    for index, case in enumerate(cases):
        if case.case_id:
            progress.case_started(index, len(cases), case.case_id)
        try:
            outcomes[case.case_id] = Concluded(run_stages(case.study, case.out_dir, progress=progress,
                                                          case=case.case_id, force=options.force,
                                                          max_memory_bytes=options.max_memory_bytes))
        except StudyError as error:
            if not case.case_id:
                raise
            raise case_error(case.case_id, error) from None
        except DivergenceError as error:
            if not placement.keep_going:
                raise
            outcomes[case.case_id] = Diverged(error)
    timings.cases_elapsed = time.perf_counter() - start
    return outcomes, timings


@dataclass
class Report:
    """What the command prints of an outcome: lines for stdout, warnings for stderr."""

    lines: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


class StudyType:
    """A kind of study (like automan's ``Problem``): the cases it makes, how they run (its
    :class:`Placement`), and how their outcomes come together into its own result and report.
    ``workflows.study_types`` lists the kinds and runs one; adding one: docs/architecture.md."""

    @property
    def label(self) -> str:
        """What the study is, for report.html: "a single study", "a sweep", ... (a class attribute of most kinds)."""
        raise NotImplementedError

    @property
    def base_note(self) -> str:
        """What the section figure of report.html shows of a study whose cases vary (a class attribute)."""
        return ""

    @property
    def placement(self) -> Placement:
        """How its cases run: a class attribute of most kinds."""
        raise NotImplementedError

    def __init__(self, study: Study, out_dir: Path):
        self.study = study
        self.out_dir = Path(out_dir)

    @staticmethod
    def applies_to(study: Study) -> bool:
        """Whether ``study`` is of this type."""
        raise NotImplementedError

    def check(self, options: RunOptions) -> None:
        """StudyError for a study that cannot run (before anything is written); none by default.
        ``spfem-fos check`` runs it too, with the same options."""

    def check_every_case(self) -> None:
        """What ``spfem-fos check`` checks beyond :meth:`check`: the cases a type makes only as they
        are about to run (:meth:`feed`), made and checked; nothing by default."""

    def processes(self, options: RunOptions) -> int:
        """The processes that hold a simulation of the study at once: this one, and for a
        strength-reduction study each local worker (``memory_guard``)."""
        if self.study.strength_reduction is None:
            return 1
        return 1 + (0 if options.scheduler else options.workers)

    def warnings(self) -> list[str]:
        """Warnings before anything runs: materials too thin for the particle spacing (``workflows.layers``),
        water above the ground with no pond (``workflows.water.table``)."""
        return thin_layer_warnings(self.study) + water_above_ground_warnings(self.study)

    def cases(self) -> list[Case]:
        """The cases to compute (their folders made where the type needs them)."""
        raise NotImplementedError

    def feed(self) -> CaseFeed | None:
        """The cases of this round made only as the case runner has room for them (beyond those
        :meth:`cases` or :meth:`next_cases` returned); none by default."""
        return None

    def case_concluded(self, case_id: str, outcome, progress: Progress) -> None:
        """A case's outcome as soon as it is known (before its round ends); nothing by default."""

    def next_cases(self, outcomes: dict, progress: Progress) -> list[Case]:
        """Cases to compute after those computed so far (``outcomes`` by case id), for a type that
        makes them in rounds (a refinement study: each level after the one before); none by default."""
        return []

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float):
        """The type's outcome from its cases' (by case id): its own result file, if any."""
        raise NotImplementedError

    def report(self, outcome, quiet: bool, study_file) -> Report:
        """What the command prints for the study read from ``study_file``."""
        raise NotImplementedError
