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
   (a dask Event the client polls every ``dask_runs.SIGNAL_POLL_S`` while it waits): the run will end
   failed, so the runs and guesses above it are stopped (``SrfSearch.deferred``: asked for again
   only if it diverges instead) and the freed worker guesses the refinement below it.

Which runs go to the workers, in what order, and when a case is decided (steps 2-6) is
``workflows.fos.planner``'s, which knows nothing of dask; the futures, their Events and the values every
worker holds are ``workflows.fos.dask_runs``'s; this module is the loop, the cases coming in and handed
back, their gravity states (step 1) and their files.

The runs a case uses, and its FOS, do not depend on the number of workers, on where its gravity
ran, or on the other cases; runs of earlier cases go first, so cases finish roughly in order.

Cases may also come as the loop has room for them (``more``: a probabilistic study's realisations,
made only when about to run): it keeps :data:`CASES_PER_WORKER` unconcluded cases per worker, and
a case handed back leaves the loop (its gravity state with it, unless it wrote it for others), so
that neither the memory nor a pass of the loop grows with the number of cases.
"""

from __future__ import annotations

import time
from pathlib import Path

from spfem_core.divergence import DivergenceError
from workflows.fos.case_search import CaseSearch, has_flow
from workflows.fos.gravity import (
    GravityResult,
    gravity_paths,
    run_gravity,
    share_gravity,
    stored_gravity,
    why_not_reused,
    write_gravity,
)
from workflows.fos.planner import Planner, TaskKind, Ticket
from workflows.fos.run_store import remove_stale_runs, run_file_name, write_run
from workflows.fos.search import SrfSearch
from workflows.fos.verdict import displacement_floor_m, failure_displacement_m
from workflows.output.writing import make_output_folder
from workflows.progress import Progress
from workflows.scene import scene_and_flow
from workflows.seepage.flow import flow_inputs
from workflows.seepage.results import flow_line
from workflows.stages.running import new_simulation
from workflows.study import StudyError
from workflows.study.reading import case_error

CASES_PER_WORKER = 4
"""With cases that come as there is room (``Engine.more``), this many unconcluded cases per worker:
enough that a worker never waits for the next case to be made (one runs, one waits on it, step 3)."""


class Engine:
    """The loop of the module doc over ``cases``, its tasks moved by ``runs`` (a
    ``workflows.fos.dask_runs.DaskRuns``, connected only once the cases placed in this process have
    their gravity); :meth:`run` yields every case as soon as its search is done."""

    def __init__(self, runs, cases: list[CaseSearch], progress: Progress, start_unix_s: float,
                 force: bool = False, more=None, to_come=None):
        self.runs = runs
        self.planner = Planner(runs, progress, start_unix_s, force)
        self.cases = list(cases)  # the cases not handed back yet
        self.more = more  # up to n more cases (a callable), or None: no more come
        self.to_come = to_come or (lambda: 0)  # how many more will come
        self.n_handed_back = 0
        self.runs_handed_back = 0  # the runs of the cases handed back
        self.written_gravity_of: dict[str, CaseSearch] = {}  # gravity key -> a case handed back that wrote its state
        self.replayed_of: dict[str, CaseSearch] = {}  # gravity key -> a case handed back that its files concluded
        self.progress = progress
        self.force = force
        self.n_workers = 1
        self.gravity_waiting: dict[str, list[CaseSearch]] = {}  # gravity key -> cases waiting for its task
        self.just_concluded: list[CaseSearch] = []  # handed back at the end of the pass
        self.stored_states: dict = {}  # (gravity folder, gravity key) -> the StressState on disk, or None
        self.gravity_written: dict[str, Path] = {}  # gravity key -> the folder this invocation wrote its files in

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
            self.planner.start(Ticket(case, TaskKind.GRAVITY))
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

    def _gravity_result(self, ticket: Ticket) -> None:
        """The gravity task of a case returned: every case waiting for its key goes on."""
        case = ticket.case
        waiting = self.gravity_waiting.pop(case.gkey)
        try:
            result = self.runs.result(ticket)
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
        removed = remove_stale_runs(case.out_dir, case.key, case.policy)
        if removed:
            self.progress.message(case.say(f"removed {removed} run files another study made (or that keep fewer "
                                           "particle fields than this one asks for)"))
        if self.force:
            remove_stale_runs(case.out_dir, lambda srf: "")  # every run file of ours: each has a key
        stage = case.study.strength_reduction
        case.search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance,
                                displacement_floor_m(case.study), n_parallel=self.n_workers, max_runs=stage.max_runs,
                                failure_m=failure_displacement_m(case.study), window=case.window,
                                top_first=case.top_first, guard=case.guard)

    def _replay(self, case: CaseSearch) -> bool:
        """The case concluded from its runs on disk alone (``Planner.replay``), no gravity needed."""
        if not self.planner.replay(case):
            return False
        case.n_particles = max((record.n_particles for record in case.runs.values()), default=0)
        case.started_s = time.perf_counter()
        self._concluded(case)
        return True

    def _prepare_search(self, case: CaseSearch) -> None:
        """The case's gravity is known: its search can run."""
        case.started_s = time.perf_counter()
        case.plan_again = True

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
        self.n_workers = self.runs.connect()
        for case in self.cases:
            self._start(case)
        planner = self.planner
        idle_passes = 0
        while True:
            self._take_more()
            for case in planner.plan([case for case in self.cases if not case.concluded]):
                self._write(case)
                self._concluded(case)
            active = [case for case in self.cases if not case.concluded]
            planner.start_runs(active)
            for case in self.cases:  # the workers are busy with the next runs meanwhile
                if case.unwritten or case.unwritten_gravity is not None:
                    self._write(case)
            self.progress.cases(self.n_handed_back + sum(case.concluded for case in self.cases),
                                self.n_handed_back + len(self.cases) + self.to_come())
            self._report_runs(active)
            if not active and self.more is None:
                planner.stop_all()
            yield from self._hand_back()
            if not active and self.more is None:
                return
            if not active:
                continue  # more cases come on the next pass
            if not planner.in_flight:  # runs were dropped from the queue above a failure: plan again
                idle_passes += 1
                if idle_passes > 3:
                    raise RuntimeError("spfem-fos engine: cases are waiting with no task running (a bug)")
                continue
            idle_passes = 0
            for ticket in self.runs.wait(lambda: planner.failures_signalled(self.runs.has_passed_failure)):
                if not planner.landed(ticket):
                    continue  # stopped meanwhile
                if ticket.kind is TaskKind.GRAVITY:
                    self._gravity_result(ticket)
                elif ticket.kind is TaskKind.RUN:
                    planner.run_finished(ticket.case, self.runs.result(ticket))  # a task's exception stops the study
                else:
                    planner.guess_finished(ticket, self.runs.result(ticket))

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
        release_gravity = False
        if case.gravity is not None and case.write_gravity:
            self.written_gravity_of.setdefault(case.gkey, case)
        elif case.gravity is None and case.write_gravity and case.error is None:  # concluded from its files alone
            self.replayed_of.setdefault(case.gkey, case)
        elif all(other.gkey != case.gkey for other in self.cases) and case.gkey not in self.gravity_waiting:
            release_gravity = True
        release_flow = has_flow(case.study) and all(flow_inputs(other.study) != flow_inputs(case.study)
                                                    for other in self.cases)
        self.runs.forget(case, gravity=release_gravity, flow=release_flow)

    def _report_runs(self, active: list[CaseSearch]) -> None:
        done = self.runs_handed_back + sum(len(case.runs) for case in self.cases)
        pending = self.planner.n_running
        finished = [case for case in self.cases if case.concluded and case.error is None]
        n_finished = self.n_handed_back + len(finished)
        per_case = ((self.runs_handed_back + sum(len(c.runs) for c in finished)) / n_finished if n_finished
                    else 8.0)
        waiting = sum(max(0.0, per_case - len(case.runs)) for case in active) + per_case * self.to_come()
        self.progress.runs(done, done + pending + int(round(waiting)))
