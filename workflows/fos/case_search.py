"""One strength-reduction case as the engine carries it: its study and folder, where its gravity
state comes from, its search (``workflows.fos.search.SrfSearch``) and the runs it has so far.

A run enters a case once, by one of two doors: :meth:`CaseSearch.reused` (its file was on disk,
made by an earlier invocation) or :meth:`CaseSearch.finished` (made now, written on the engine's
next pass); either tells the search its outcome.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

from spfem_core.divergence import DivergenceError
from spfem_core.snapshot import StressState
from workflows.fos.gravity import GravityResult
from workflows.fos.keys import gravity_key, run_key
from workflows.fos.search import SrfSearch
from workflows.fos.task import RunPolicy, RunRecord, SrfRunResult
from workflows.scene import water_flow
from workflows.study import Study


@dataclass
class CaseSearch:
    """One strength-reduction case in the engine: its study and folder, gravity, search and runs."""

    index: int
    study: Study
    out_dir: Path
    label: str = ""  # how messages name the case ("" for a single study)
    gravity_here: bool = False  # compute its gravity in this process (``fos.engine``, step 1)
    gravity_dir: Path | None = None  # where its gravity files are (default out_dir; cases may share one)
    write_gravity: bool = True  # False: its gravity state is never written (recomputed if needed again)
    policy: RunPolicy = field(default_factory=RunPolicy)  # what its runs keep, and when they end
    gravity: StressState | None = None  # once known
    flow: object = None  # its steady flow (``workflows.seepage.flow.StudyFlow``), once solved: for its runs and figures
    gravity_reused: bool = False
    gravity_wall_s: float = 0.0
    n_particles: int = 0
    search: SrfSearch | None = None
    runs: dict[float, RunRecord] = field(default_factory=dict)  # srf -> the run's record
    unwritten: list[SrfRunResult] = field(default_factory=list)  # written on the next pass
    unwritten_gravity: GravityResult | None = None  # written on the next pass
    reused_runs: int = 0
    n_guessed: int = 0
    n_guesses_used: int = 0
    io_s: float = 0.0
    error: DivergenceError | None = None  # the gravity stage diverged: no search
    concluded: bool = False
    started_s: float = 0.0  # wall clock (perf_counter) when its search could begin
    plan_again: bool = True  # something its search plans on has changed since it was last asked
    planned_parallel: int = 0  # the search's n_parallel when it was last asked
    window: tuple[float, float, float] | None = None  # (low, high, step) its search starts in (fos.prediction)
    top_first: bool = False  # its search runs srf_max first, alone (``fos.search``, step 6)
    guard: float | None = None  # with top_first: the SRF run next where srf_max failed (``fos.search``, step 6)

    def __post_init__(self):
        if self.gravity_dir is None:
            self.gravity_dir = self.out_dir

    @functools.cached_property
    def gkey(self) -> str:
        return gravity_key(self.study)

    def key(self, srf: float) -> str:
        """The run key of its run at ``srf`` (``workflows.fos.keys``)."""
        return run_key(self.study, srf, self.policy.stop_at_failure)

    @property
    def single_run(self) -> bool:
        """Its search makes one run (srf_min = srf_max): nothing to cancel, nothing to plan on early."""
        stage = self.study.strength_reduction
        return stage.srf_min == stage.srf_max

    def say(self, text: str) -> str:
        return f"{self.label}: {text}" if self.label else text

    def steady_flow(self):
        """Its flow, solved here once if nobody has given it one (``workflows.scene.water_flow``)."""
        if self.flow is None:
            self.flow = water_flow(self.study)
        return self.flow

    def reused(self, record: RunRecord) -> None:
        """A started run found on disk, made by an earlier invocation."""
        self.runs[record.srf] = record
        self.reused_runs += 1
        self.search.finished(record.outcome)

    def finished(self, result: SrfRunResult, study_start_unix_s: float) -> RunRecord:
        """A run made now: its record (its start and end since the study started), its file to write."""
        record = result.record_since(study_start_unix_s)
        self.plan_again = True
        self.runs[record.srf] = record
        self.unwritten.append(result)
        self.search.finished(record.outcome)
        return record


def has_flow(study: Study) -> bool:
    """Whether the study's water comes from a flow (``[seepage]`` or ``[transient]``) its runs share."""
    return study.seepage is not None or study.transient is not None
