"""The SRF runs of one or many strength-reduction cases on one dask cluster.

Every case (one study, or one case of a sweep) has its gravity state, its own search
(``workflows.fos.search.SrfSearch``) and its own folder.  One loop in the client keeps the
workers busy with all of them at once, with no barrier between cases:

1. a case whose every run its search asks for is on disk already is concluded from them, with
   no gravity state (a finished case of an interrupted study); a case without a gravity state
   reuses the one on disk for its key (in its gravity folder, read once for the cases that share
   it, or in the folder of another case with the same key), or computes it (``workflows.fos.gravity``):
   in this process before the cluster is needed, for a case placed so (a single study: its
   gravity runs on all cores while the cluster starts), else as a gravity task on a worker, whose
   files the client writes when it returns; cases with the same gravity key (a sweep over
   strength with an elastic gravity stage) share one, and its files: written once, hard-linked
   into the other cases' folders (``fos.gravity.share_gravity``);
2. every case with a gravity state asks its search for the next SRF values; each is reused
   from disk when a file with its key exists, else queued.  With several cases running, a case
   releases fewer sweep values at once (the search's ``n_parallel``), as the other cases keep
   the workers busy;
3. queued runs are submitted as tasks (``workflows.fos.task.run_srf``) only as workers free
   up, earlier cases and lower SRF first: a task submitted ahead would be placed on a busy
   worker's queue by the scheduler while the other worker idled (the runs of cases of one run
   each, a probabilistic study's realisations, go one per worker ahead: none is ever stopped);
4. finished runs are written, runs above a case's first failure are cancelled or dropped from
   the queue (they cannot move its knee), and a case whose search is done is handed back
   (:meth:`Engine.run` yields it) to be concluded (its ``summary.nc``);
5. only when the queue is empty, an idle worker runs a guess: a value a case's search would
   ask for next under either outcome of its one undecided run (``SrfSearch.speculative_values``),
   used only if the search then asks for it.  A guess gives way (is stopped) as soon as a
   queued run needs its worker;
6. a run tells the client as soon as its largest displacement passes the failure displacement
   (a dask Event the client polls every ``SIGNAL_POLL_S`` while it waits): the run will end
   failed, so the runs and guesses above it are stopped (``SrfSearch.deferred``: asked for again
   only if it diverges instead) and the freed worker guesses the refinement below it.

The runs a case uses, and its FOS, do not depend on the number of workers, on where its gravity
ran, or on the other cases; runs of earlier cases go first, so cases finish roughly in order.

Cases may also come as the loop has room for them (``more``: a probabilistic study's realisations,
made only when about to run): it keeps :data:`CASES_PER_WORKER` unconcluded cases per worker, and
a case handed back leaves the loop (its gravity state with it, unless it wrote it for others), so
that neither the memory nor a pass of the loop grows with the number of cases.
"""

from __future__ import annotations

import enum
import functools
import math
import time
import uuid
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from distributed import Client, Event, wait

from spfem_core.divergence import DivergenceError
from spfem_core.snapshot import StressState
from workflows.fos.gravity import (
    GravityResult,
    gravity_paths,
    run_gravity,
    share_gravity,
    stored_gravity,
    why_not_reused,
    write_gravity,
)
from workflows.fos.keys import gravity_key, run_key
from workflows.fos.run_store import remove_stale_runs, run_file_name, stored_run, write_run
from workflows.fos.search import SrfSearch
from workflows.fos.task import RunPolicy, RunRecord, SrfRunResult, held, run_srf
from workflows.fos.verdict import DIVERGED, displacement_floor_m, failure_displacement_m
from workflows.output.writing import make_output_folder
from workflows.progress import Progress
from workflows.scene import scene_and_flow, water_flow
from workflows.seepage.flow import flow_inputs
from workflows.seepage.results import flow_line
from workflows.stages.running import new_simulation
from workflows.study import Study, StudyError
from workflows.study.reading import case_error


@dataclass
class CaseSearch:
    """One strength-reduction case in the engine: its study and folder, gravity, search and runs."""

    index: int
    study: Study
    out_dir: Path
    label: str = ""  # how messages name the case ("" for a single study)
    gravity_here: bool = False  # compute its gravity in this process (step 1)
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
    shared: tuple = ()  # (study, the futures of its gravity state and steady flow on the workers) for its runs
    plan_again: bool = True  # something its search plans on has changed since it was last asked
    planned_parallel: int = 0  # the search's n_parallel when it was last asked
    window: tuple[float, float, float] | None = None  # (low, high, step) its search starts in (fos.prediction)

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


def has_flow(study: Study) -> bool:
    """Whether the study's water comes from a flow (``[seepage]`` or ``[transient]``) its runs share."""
    return study.seepage is not None or study.transient is not None


CASES_PER_WORKER = 4
"""With cases that come as there is room (``Engine.more``), this many unconcluded cases per worker:
enough that a worker never waits for the next case to be made (one runs, one waits on it, step 3)."""

SIGNAL_POLL_S = 0.2
"""While waiting for a task, the client checks this often whether a running run has passed the
failure displacement (module doc, step 6): one scheduler round trip per running run."""


class TaskKind(enum.Enum):
    """What a submitted task is for."""

    GRAVITY = "gravity"  # a case's gravity state
    RUN = "run"  # an SRF run the search asked for
    GUESS = "guess"  # an SRF run started ahead of the search (step 5)


@dataclass
class _Task:
    """A submitted (or queued) task: what it is for."""

    case: CaseSearch
    kind: TaskKind
    srf: float = math.nan
    key: str = ""
    event: str = ""  # the Event that stops the run
    failing_event: str = ""  # the Event the run sets once it has passed the failure displacement


class Engine:
    """The loop of the module doc over ``cases`` on the client of ``session`` (a
    ``workflows.fos.cluster.DaskSession``, asked for its client only once the cases placed in this
    process have their gravity); :meth:`run` yields every case as soon as its search is done."""

    def __init__(self, session, cases: list[CaseSearch], progress: Progress, start_unix_s: float,
                 force: bool = False, more=None, to_come=None):
        self.session = session
        self.client: Client | None = None
        self.cases = list(cases)  # the cases not handed back yet
        self.more = more  # up to n more cases (a callable), or None: no more come
        self.to_come = to_come or (lambda: 0)  # how many more will come
        self.n_handed_back = 0
        self.runs_handed_back = 0  # the runs of the cases handed back
        self.written_gravity_of: dict[str, CaseSearch] = {}  # gravity key -> a case handed back that wrote its state
        self.replayed_of: dict[str, CaseSearch] = {}  # gravity key -> a case handed back that its files concluded
        self.progress = progress
        self.start_unix_s = start_unix_s
        self.force = force
        self.n_workers = 1
        self.token = uuid.uuid4().hex[:12]
        self.tasks: dict = {}  # future -> _Task
        self.guesses: dict = {}  # (case index, srf) -> future of a guess still running
        self.guesses_done: dict = {}  # (case index, srf) -> SrfRunResult
        self.gravity_waiting: dict[str, list[CaseSearch]] = {}  # gravity key -> cases waiting for its task
        self.queue: list[_Task] = []  # runs asked for, not yet submitted (step 3)
        self.just_concluded: list[CaseSearch] = []  # handed back at the end of the pass
        self.n_submitted = 0
        self.stored_states: dict = {}  # (gravity folder, gravity key) -> the StressState on disk, or None
        self.gravity_written: dict[str, Path] = {}  # gravity key -> the folder this invocation wrote its files in
        self.scattered: dict = {}  # gravity key -> the future of that gravity state on every worker
        self.flows: dict = {}  # the inputs of a steady flow (seepage.flow.flow_inputs) -> its future on every worker

    # ------------------------------------------------------------------ submitting
    def _submit(self, function, *args, priority: int, **kwargs):
        self.n_submitted += 1
        return self.client.submit(function, *args, priority=priority, pure=False, **kwargs)

    def _submit_run(self, case: CaseSearch, srf: float, key: str, kind: TaskKind):
        """A run task.  A case that makes one run gets no Events: it has nothing to stop or plan on
        early, and each Event costs its run a scheduler round trip per stop-rule check."""
        if not case.shared:
            if case.gkey not in self.scattered:  # once per gravity state, whatever the cases sharing it
                self.scattered[case.gkey] = self._on_every_worker(case.gravity, f"gravity-state-{case.gkey}")
            flow = None
            if has_flow(case.study):  # the client's flow: the workers do not solve it again
                inputs = flow_inputs(case.study)
                if inputs not in self.flows:
                    case.flow = water_flow(case.study) if case.flow is None else case.flow
                    self.flows[inputs] = self._on_every_worker(case.flow, f"steady-flow-{case.gkey}-{len(self.flows)}")
                flow = self.flows[inputs]
            case.shared = (case.study, self.scattered[case.gkey], flow)
        name = f"{key}-{self.token}-{self.n_submitted + 1}"
        event, failing = ("", "") if case.single_run else (f"spfem-fos-cancel-{name}", f"spfem-fos-failing-{name}")
        study, gravity, flow = case.shared
        future = self._submit(run_srf, study, gravity, srf, cancel_event=event or None, run_key=key,
                              gravity_key=case.gkey, failing_event=failing or None, policy=case.policy, flow=flow,
                              key=f"srf-{srf:.4f}-{name}", priority=-case.index)
        self.tasks[future] = _Task(case, kind, srf, key, event, failing)
        return future

    def _on_every_worker(self, value, name: str):
        """``value`` as a task's result replicated to every worker (``fos.task.held``)."""
        future = self.client.submit(held, value, pure=False, priority=2_000_000, key=f"{name}-{self.token}")
        wait([future])
        self.client.replicate([future])  # on every worker now: runs go wherever a worker is free
        return future

    def _cancel(self, future) -> None:
        """Stop a run at its next check (its worker is free then) and forget it."""
        task = self.tasks.pop(future)
        if task.event:
            Event(task.event, client=self.client).set()
        future.cancel()

    # ------------------------------------------------------------------ gravity (step 1)
    def _stored_state(self, case: CaseSearch):
        """The gravity state in the case's gravity folder for its key, or None (read once for all the
        cases that share the folder and key; never with ``force``)."""
        if self.force:
            return None
        slot = (case.gravity_dir, case.gkey)
        if slot not in self.stored_states:
            self.stored_states[slot] = stored_gravity(case.study, case.gravity_dir)
        return self.stored_states[slot]

    def _load_stored_gravity(self, case: CaseSearch) -> None:
        """The case's gravity state from its gravity folder, when its files and key are there."""
        if case.gravity is None:
            state = self._stored_state(case)
            if state is not None:
                case.gravity, case.gravity_reused, case.n_particles = state, True, state.n_particles

    def _gravity_here(self, case: CaseSearch) -> None:
        """The case's gravity state computed in this process (all cores, with the study's snapshots),
        or reused from its gravity folder once the study's scene passes its checks and has the
        particles of the stored state."""
        study, out_dir = case.study, case.gravity_dir
        stored = None if self.force else stored_gravity(study, out_dir)
        path = gravity_paths(study, out_dir)[-1]
        if stored is not None:
            scene, flow = scene_and_flow(study, case.flow)
            new_simulation(study, scene)  # the study's checks, as when the state is computed
            if stored.n_particles == scene.n_particles:
                case.gravity, case.gravity_reused, case.n_particles = stored, True, stored.n_particles
                case.flow = flow
                self.progress.message(case.say(f"gravity state reused from {path} (its inputs are unchanged)"))
                return
        if not self.force and path.is_file():
            reason = why_not_reused(study, out_dir) if stored is None else f"{path.name} has another particle count"
            self.progress.message(case.say(f"gravity state relaxed again: {reason}"))
        result = run_gravity(study.source_text, threads=0, out_dir=out_dir, progress=self.progress, case=case.label,
                             flow=case.flow)
        write_gravity(study, out_dir, result)
        if result.flow is not None:  # a transient study's water at its time, or the steady flow
            self.progress.message(case.say(result.flow.line() if study.transient is not None else flow_line(result.flow)))
        self._gravity_done(case, result, computed=True, written=True)

    def _start(self, case: CaseSearch) -> None:
        """The case concluded from its runs on disk, or its gravity: from its gravity folder, from
        another case with the same gravity key (its files shared where the case keeps its own), or a
        gravity task (shared by the cases with its key)."""
        if case.search is None:
            self._new_search(case)
        if case.gravity is None and self._replay(case):
            return
        self._load_stored_gravity(case)
        if case.gravity is None:
            donor = next((c for c in self.cases if c.gravity is not None and c.gkey == case.gkey),
                         self.written_gravity_of.get(case.gkey))
            if donor is None:  # a case with this key that concluded from its files alone: its gravity files
                concluded_alone = [self.replayed_of[case.gkey]] if case.gkey in self.replayed_of else []
                donor = next((c for c in self.cases + concluded_alone if c.gkey == case.gkey and c is not case
                              and self._stored_state(c) is not None), None)
                if donor is not None:
                    donor.gravity, donor.gravity_reused = self._stored_state(donor), True
                    donor.n_particles = donor.gravity.n_particles
            if donor is not None:
                if case.write_gravity and donor.gravity_dir != case.gravity_dir:
                    share_gravity(case.study, donor.gravity_dir, case.gravity_dir)
                case.gravity, case.gravity_reused, case.n_particles = donor.gravity, True, donor.n_particles
        if case.gravity is None:
            waiting = self.gravity_waiting.get(case.gkey)
            if waiting is not None:  # the same gravity state is on its way for an earlier case
                waiting.append(case)
                return
            future = self._submit(run_gravity, case.study.source_text, flow=case.flow, priority=1_000_000 - case.index,
                                  key=f"gravity-{case.gkey}-{self.token}-{case.index}")
            self.tasks[future] = _Task(case, TaskKind.GRAVITY)
            self.gravity_waiting[case.gkey] = [case]
            return
        self._prepare_search(case)

    def _gravity_done(self, case: CaseSearch, result: GravityResult, computed: bool, written: bool = False) -> None:
        """``computed``: the gravity ran for this case (else it shares another case's state).  Its
        files are written on the next pass, once the case's first runs are on their way."""
        if computed:
            for name in result.unconverged:
                self.progress.message(case.say(f"warning: stage {name!r} reached max_duration_s before converging"))
        case.unwritten_gravity = None if written else result
        case.gravity = result.state
        case.flow = result.flow  # solved with the gravity state (here or by its worker): not again here
        case.n_particles, case.gravity_wall_s = result.n_particles, result.wall_time_s if computed else 0.0

    def _gravity_result(self, case: CaseSearch, future) -> None:
        """The gravity task of ``case`` returned: every case waiting for its key goes on."""
        waiting = self.gravity_waiting.pop(case.gkey)
        try:
            result = future.result()
        except StudyError as error:  # the scene of a sweep's case
            if not case.label:
                raise
            raise case_error(case.label, error) from None
        except DivergenceError as error:  # a diverged gravity stage ends these cases only
            for each in waiting:
                each.error = error
                self.progress.message(each.say(f"warning: the gravity stage diverged: {error}"))
                self._concluded(each)
            return
        for each in waiting:
            written = not each.write_gravity or (each is not case and each.gravity_dir == case.gravity_dir)
            self._gravity_done(each, result, computed=each is case, written=written)
            self._prepare_search(each)

    # ------------------------------------------------------------------ one case
    def _new_search(self, case: CaseSearch) -> None:
        """The case's folder without files another study made, and its search."""
        make_output_folder(case.out_dir)
        removed = remove_stale_runs(case.out_dir, case.key)
        if removed:
            self.progress.message(case.say(f"removed {removed} run files another study made"))
        if self.force:
            remove_stale_runs(case.out_dir, lambda srf: "")  # every run file of ours: each has a key
        stage = case.study.strength_reduction
        case.search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance,
                                displacement_floor_m(case.study), n_parallel=self.n_workers, max_runs=stage.max_runs,
                                failure_m=failure_displacement_m(case.study), window=case.window)

    def _replay(self, case: CaseSearch) -> bool:
        """Feed the search the runs it asks for while some of them are on disk (of a batch, those that are:
        a value beside them that an earlier invocation never ran, cancelled above one of them that failed,
        is then no longer asked for); True (the case concluded, no gravity needed) if that finishes it.
        Otherwise the search stands where it asks only for missing runs, and the loop plans from there
        once the gravity is known."""
        if self.force:
            return False
        search = case.search
        while True:
            planned = search.next_values()
            if not planned:
                break
            stored = [stored_run(case.out_dir / run_file_name(srf), case.key(srf), case.policy) for srf in planned]
            found = [record for record in stored if record is not None]
            if not found:
                return False
            for record in found:  # (a value missing beside them may be one the search no longer asks for once
                search.started(record.srf)  # it knows these: above one of them that failed, as when they ran)
                self._reused(case, record)
        if search.pending:
            return False
        case.n_particles = max((record.n_particles for record in case.runs.values()), default=0)
        case.started_s = time.perf_counter()
        self._concluded(case)
        return True

    def _prepare_search(self, case: CaseSearch) -> None:
        """The case's gravity is known: its search can run."""
        case.started_s = time.perf_counter()
        case.plan_again = True

    @staticmethod
    def _reused(case: CaseSearch, record: RunRecord) -> None:
        """A started run of the case found on disk, made by an earlier invocation."""
        case.runs[record.srf] = record
        case.reused_runs += 1
        case.search.finished(record.outcome)

    def _finished(self, case: CaseSearch, result: SrfRunResult) -> None:
        record = result.record_since(self.start_unix_s)
        case.plan_again = True
        case.runs[record.srf] = record
        case.unwritten.append(result)
        case.search.finished(record.outcome)
        if record.status == DIVERGED:
            self.progress.message(case.say(f"warning: SRF {record.srf:g} diverged: {record.status_reason}"))

    def _pending(self) -> Counter:
        """Case index -> its runs and gravity task not finished yet: running or queued."""
        counts = Counter(t.case.index for t in self.tasks.values() if t.kind in (TaskKind.RUN, TaskKind.GRAVITY))
        counts.update(t.case.index for t in self.queue)
        return counts

    def _cancel_guesses(self, case: CaseSearch) -> None:
        """Stop the case's guesses still running."""
        for (index, srf), future in list(self.guesses.items()):
            if index == case.index:
                self._cancel(future)
                del self.guesses[(index, srf)]

    def _plan(self, case: CaseSearch, n_parallel: int, n_pending: int) -> None:
        """Ask the case's search for values until something runs or it has nothing more to ask;
        hand the case back when its search is done.  ``n_pending``: its runs (and gravity task)
        running or queued when the pass began."""
        search = case.search
        search.n_parallel = case.planned_parallel = n_parallel
        case.plan_again = False
        while True:
            planned = search.next_values()
            for srf in planned:
                search.started(srf)
                guess = (case.index, srf)
                if guess in self.guesses_done:  # a guess that came true, already finished
                    case.n_guesses_used += 1
                    self._finished(case, self.guesses_done.pop(guess))
                    continue
                if guess in self.guesses:  # a guess that came true, still running
                    case.n_guesses_used += 1
                    self.tasks[self.guesses.pop(guess)].kind = TaskKind.RUN
                    n_pending += 1
                    continue
                key = case.key(srf)
                stored = stored_run(case.out_dir / run_file_name(srf), key, case.policy)
                if stored is not None:
                    self._reused(case, stored)
                    continue
                self.queue.append(_Task(case, TaskKind.RUN, srf, key))
                n_pending += 1
            if planned:  # the decision the case's guesses were made for is taken: stop the unused ones
                self._cancel_guesses(case)
            if n_pending or not planned:
                break  # waiting for runs, or done
        if not n_pending:
            self._cancel_guesses(case)  # no decision left to guess ahead of
            self._write(case)
            self._concluded(case)

    def _concluded(self, case: CaseSearch) -> None:
        case.concluded = True
        self.just_concluded.append(case)

    def _write(self, case: CaseSearch) -> None:
        start = time.perf_counter()
        if case.unwritten_gravity is not None:  # written once per key, shared by the other cases' folders
            written_in = self.gravity_written.get(case.gkey)
            if written_in is None or written_in == case.gravity_dir:
                write_gravity(case.study, case.gravity_dir, case.unwritten_gravity)
                self.gravity_written[case.gkey] = case.gravity_dir
            else:
                share_gravity(case.study, written_in, case.gravity_dir)
            case.unwritten_gravity = None
        for result in case.unwritten:  # the workers are busy with the next runs meanwhile
            write_run(result, case.out_dir / run_file_name(result.srf))
        case.unwritten.clear()
        case.io_s += time.perf_counter() - start

    def _cancel_above_failures(self) -> None:
        """Stop the runs and guesses that can no longer move their case's knee: above a failed run,
        or above a run known to fail (step 6); their workers are free for runs that can."""
        for future, task in list(self.tasks.items()):
            if task.kind is TaskKind.GRAVITY or task.case.single_run or not task.case.search.above_failure(task.srf):
                continue
            self._cancel(future)
            task.case.plan_again = True
            if task.kind is TaskKind.RUN:
                task.case.search.withdraw(task.srf)
            else:
                self.guesses.pop((task.case.index, task.srf), None)
        if any(not task.case.single_run for task in self.queue):
            for task in list(self.queue):
                if not task.case.single_run and task.case.search.above_failure(task.srf):
                    task.case.search.withdraw(task.srf)
                    task.case.plan_again = True
                    self.queue.remove(task)

    def _failures_signalled(self) -> bool:
        """Tell each case's search which of its running runs have passed the failure displacement
        since the last look; whether any has."""
        news = False
        for task in list(self.tasks.values()):
            search = task.case.search
            if task.kind is not TaskKind.RUN or not task.failing_event or task.srf in search.failing:
                continue
            if Event(task.failing_event, client=self.client).is_set():
                search.passed_failure(task.srf)
                task.case.plan_again = True
                news = True
        return news

    def _wait(self) -> list:
        """The tasks that finished, once one has; [] as soon as a running run is known to fail
        (module doc, step 6), so that the loop plans again.  A cluster left without workers ends
        the study (``DaskSession.check_workers``): dask would wait for one forever."""
        while True:
            try:
                finished, _ = wait(list(self.tasks), timeout=SIGNAL_POLL_S, return_when="FIRST_COMPLETED")
                return list(finished)
            except TimeoutError:
                if self._failures_signalled():
                    return []
                self.session.check_workers()

    def _dispatch(self) -> None:
        """Submit queued runs to free workers, earlier cases and lower SRF first (step 3); a
        running guess is stopped when a queued run needs its worker.  The run of a case of one run
        (a realisation) may also wait on a busy worker, one per worker: nothing stops or reorders it,
        and the worker starts it without waiting for the client to hear of the last one."""
        self.queue.sort(key=lambda task: (task.case.index, task.srf))
        while self.queue:
            ahead = self.n_workers if self.queue[0].case.single_run else 0
            if len(self.tasks) >= self.n_workers + ahead:
                guesses = [f for f, t in self.tasks.items() if t.kind is TaskKind.GUESS]
                if not guesses:
                    return
                task = self.tasks[guesses[-1]]
                self._cancel(guesses[-1])
                self.guesses.pop((task.case.index, task.srf), None)
            task = self.queue.pop(0)
            self._submit_run(task.case, task.srf, task.key, TaskKind.RUN)

    def _guess(self, active: list[CaseSearch]) -> None:
        """Guesses on idle workers, for cases with one undecided run (module doc, step 5)."""
        idle = self.n_workers - len(self.tasks) if not self.queue else 0
        for case in active:
            if idle <= 0:
                return
            if case.gravity is None:
                continue
            known = {srf for (index, srf) in list(self.guesses) + list(self.guesses_done) if index == case.index}
            for srf in [f for f in case.search.speculative_values(idle + len(known)) if f not in known][:idle]:
                key = case.key(srf)
                if stored_run(case.out_dir / run_file_name(srf), key, case.policy) is not None:
                    continue  # on disk already: reused when asked for
                self.guesses[(case.index, srf)] = self._submit_run(case, srf, key, TaskKind.GUESS)
                case.n_guessed += 1
                idle -= 1

    # ------------------------------------------------------------------ the loop
    def run(self):
        """Run every case (module doc); yield each one as soon as its search is done (or its gravity
        stage diverged: ``case.error``).  A single case whose gravity diverges raises the
        DivergenceError instead."""
        relaxed = set()
        for case in self.cases:  # before the cluster is needed: it starts meanwhile
            if case.gravity_here and case.gkey not in relaxed:  # once per key: _start shares it with the others
                self._gravity_here(case)
                relaxed.add(case.gkey)
        self.client = self.session.client()
        self.n_workers = max(1, sum(self.client.nthreads().values()))
        for case in self.cases:
            self._start(case)
        idle_passes = 0
        while True:
            self._take_more()
            active = [case for case in self.cases if not case.concluded]
            pending = self._pending()
            n_parallel = max(1, math.ceil(self.n_workers / max(len(active), 1)))
            for case in active:  # a case whose search has learnt nothing new would ask for nothing new
                if case.gravity is None or case.error is not None:
                    continue
                if case.plan_again or not pending[case.index] or case.planned_parallel != n_parallel:
                    self._plan(case, n_parallel, pending[case.index])
            self._cancel_above_failures()
            self._dispatch()
            active = [case for case in self.cases if not case.concluded]
            if active:
                self._guess(active)
            for case in self.cases:  # the workers are busy with the next runs meanwhile
                if case.unwritten or case.unwritten_gravity is not None:
                    self._write(case)
            self.progress.cases(self.n_handed_back + sum(case.concluded for case in self.cases),
                                self.n_handed_back + len(self.cases) + self.to_come())
            self._report_runs(active)
            if not active and self.more is None:
                for future in list(self.tasks):
                    self._cancel(future)
            yield from self._hand_back()
            if not active and self.more is None:
                return
            if not active:
                continue  # more cases come on the next pass
            if not self.tasks:  # runs were dropped from the queue above a failure: plan again
                idle_passes += 1
                if idle_passes > 3:
                    raise RuntimeError("spfem-fos engine: cases are waiting with no task running (a bug)")
                continue
            idle_passes = 0
            for future in self._wait():
                task = self.tasks.pop(future, None)
                if task is None:
                    continue  # cancelled meanwhile
                if task.kind is TaskKind.GRAVITY:
                    self._gravity_result(task.case, future)
                elif task.kind is TaskKind.RUN:
                    self._finished(task.case, future.result())  # a task's exception stops the study
                else:
                    self.guesses.pop((task.case.index, task.srf), None)
                    self.guesses_done[(task.case.index, task.srf)] = future.result()

    @property
    def all_concluded(self) -> bool:
        """Every case concluded, and none to come."""
        return self.more is None and all(case.concluded for case in self.cases)

    def _take_more(self) -> None:
        """Cases from ``more`` while fewer than :data:`CASES_PER_WORKER` per worker are unconcluded, each
        started (step 1: one whose runs are all on disk concludes at once, and another is taken)."""
        unconcluded = sum(not case.concluded for case in self.cases)
        while self.more is not None:
            room = CASES_PER_WORKER * self.n_workers - unconcluded
            if room <= 0:
                return
            cases = self.more(room)
            if not cases:
                if not self.to_come():
                    self.more = None
                elif unconcluded == 0 and not self.just_concluded:
                    raise RuntimeError("spfem-fos engine: cases are to come but none is given while none runs (a bug)")
                return
            self.cases += cases
            for case in cases:
                self._start(case)
            unconcluded += sum(not case.concluded for case in cases)

    def _hand_back(self):
        """The cases concluded in this pass (a lone case whose gravity diverged: its error, raised); each
        leaves the loop, its gravity state kept only where it wrote it for the cases to come."""
        done, self.just_concluded = self.just_concluded, []
        lone = self.more is None and self.n_handed_back + len(self.cases) == 1
        for case in done:
            if case.error is not None and lone:
                raise case.error
        if done:
            leaving = {id(case) for case in done}
            self.cases = [case for case in self.cases if id(case) not in leaving]
            for case in done:
                self._retire(case)
        yield from done

    def _retire(self, case: CaseSearch) -> None:
        """A case handed back: counted, and its gravity state and flow released on the workers unless a
        case still here shares them (a written one stays known for the cases to come)."""
        self.n_handed_back += 1
        self.runs_handed_back += len(case.runs)
        if case.gravity is not None and case.write_gravity:
            self.written_gravity_of.setdefault(case.gkey, case)
        elif case.gravity is None and case.write_gravity and case.error is None:  # concluded from its files alone
            self.replayed_of.setdefault(case.gkey, case)
        elif all(other.gkey != case.gkey for other in self.cases) and case.gkey not in self.gravity_waiting:
            self.scattered.pop(case.gkey, None)
        if has_flow(case.study):
            inputs = flow_inputs(case.study)
            if all(flow_inputs(other.study) != inputs for other in self.cases):
                self.flows.pop(inputs, None)
        case.shared = ()

    def _report_runs(self, active: list[CaseSearch]) -> None:
        done = self.runs_handed_back + sum(len(case.runs) for case in self.cases)
        pending = sum(1 for task in self.tasks.values() if task.kind is TaskKind.RUN)
        finished = [case for case in self.cases if case.concluded and case.error is None]
        n_finished = self.n_handed_back + len(finished)
        per_case = ((self.runs_handed_back + sum(len(c.runs) for c in finished)) / n_finished if n_finished
                    else 8.0)
        waiting = sum(max(0.0, per_case - len(case.runs)) for case in active) + per_case * self.to_come()
        self.progress.runs(done, done + pending + int(round(waiting)))
