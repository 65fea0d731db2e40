"""Which SRF runs of many cases' searches go to the workers next, and when a case is decided.

The planner knows nothing of dask: it hands a :class:`Ticket` to its runner (``start``, ``stop``;
``workflows.fos.dask_runs`` on a cluster, a scripted function in the tests) and is told what came
back.  Its rules (the steps of ``workflows.fos.engine``'s module doc):

- a case's search is asked for values only when something it plans on has changed (a run finished,
  was withdrawn or passed the failure displacement, or the share of workers per case changed); each
  value is a guess that came true, a run on disk, or queued.  A case with nothing running or queued
  after its search was asked is **decided** (:meth:`Planner.plan` returns it);
- the queue goes to free workers earlier cases and lower SRF first; a case of one run (a
  realisation) may also wait on a busy worker, one per worker;
- runs and guesses above a case's failure (known, or signalled early) are stopped or dropped;
- only with the queue empty, an idle worker runs a guess (``SrfSearch.speculative_values``), which
  gives way as soon as a queued run needs its worker.
"""

from __future__ import annotations

import enum
import math
from collections import Counter
from dataclasses import dataclass
from typing import Protocol

from workflows.fos.case_search import CaseSearch
from workflows.fos.run_store import run_file_name, stored_run
from workflows.fos.task import SrfRunResult
from workflows.fos.verdict import DIVERGED
from workflows.progress import Progress


class TaskKind(enum.Enum):
    """What a submitted task is for."""

    GRAVITY = "gravity"  # a case's gravity state
    RUN = "run"  # an SRF run the search asked for
    GUESS = "guess"  # an SRF run started ahead of the search


@dataclass(eq=False)
class Ticket:
    """A task queued or handed to the runner: what it is for (one object per task, by identity)."""

    case: CaseSearch
    kind: TaskKind
    srf: float = math.nan
    key: str = ""  # the run key (``workflows.fos.keys``) of a run or guess


class Runner(Protocol):
    """What moves the planner's tasks: starts one, stops one (its worker free at once)."""

    n_workers: int

    def start(self, ticket: Ticket) -> None: ...

    def stop(self, ticket: Ticket) -> None: ...


class Planner:
    """The rules of the module doc over the cases the engine gives it."""

    def __init__(self, runner: Runner, progress: Progress, start_unix_s: float, force: bool = False):
        self.runner = runner
        self.progress = progress
        self.start_unix_s = start_unix_s
        self.force = force
        self.in_flight: list[Ticket] = []  # started, not finished or stopped, in the order started
        self.queue: list[Ticket] = []  # runs asked for, not yet started
        self.guesses: dict[tuple[int, float], Ticket] = {}  # (case index, srf) -> a guess still running
        self.guesses_done: dict[tuple[int, float], SrfRunResult] = {}  # (case index, srf) -> a finished guess

    # ------------------------------------------------------------------ tasks in and out
    def start(self, ticket: Ticket) -> None:
        self.runner.start(ticket)
        self.in_flight.append(ticket)

    def _stop(self, ticket: Ticket) -> None:
        """Stop a task at its next check (its worker is free then) and forget it."""
        self.in_flight.remove(ticket)
        self.runner.stop(ticket)

    def stop_all(self) -> None:
        for ticket in list(self.in_flight):
            self._stop(ticket)

    def landed(self, ticket: Ticket) -> bool:
        """A task came back: no longer in flight.  False if it had been stopped meanwhile."""
        if ticket not in self.in_flight:
            return False
        self.in_flight.remove(ticket)
        return True

    def run_finished(self, case: CaseSearch, result: SrfRunResult) -> None:
        record = case.finished(result, self.start_unix_s)
        if record.status == DIVERGED:
            self.progress.message(case.say(f"warning: SRF {record.srf:g} diverged: {record.status_reason}"))

    def guess_finished(self, ticket: Ticket, result: SrfRunResult) -> None:
        """Kept out of the case's search until the search asks for that value."""
        self.guesses.pop((ticket.case.index, ticket.srf), None)
        self.guesses_done[(ticket.case.index, ticket.srf)] = result

    @property
    def n_running(self) -> int:
        """Runs the searches asked for, started and not finished."""
        return sum(1 for ticket in self.in_flight if ticket.kind is TaskKind.RUN)

    def _pending(self) -> Counter:
        """Case index -> its runs and gravity task not finished yet: running or queued."""
        counts = Counter(t.case.index for t in self.in_flight if t.kind in (TaskKind.RUN, TaskKind.GRAVITY))
        counts.update(t.case.index for t in self.queue)
        return counts

    # ------------------------------------------------------------------ one case
    def replay(self, case: CaseSearch) -> bool:
        """Feed the search the runs it asks for while some of them are on disk (of a batch, those that
        are: a value beside them that an earlier invocation never ran, cancelled above one of them that
        failed, is then no longer asked for); True (the case is decided, no gravity needed) if that
        finishes it.  Otherwise the search stands where it asks only for missing runs, and is planned
        from there once the gravity is known."""
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
            for record in found:
                search.started(record.srf)
                case.reused(record)
        return not search.pending

    def _plan(self, case: CaseSearch, n_parallel: int, n_pending: int) -> bool:
        """Ask the case's search for values until something runs or it has nothing more to ask;
        whether it is decided.  ``n_pending``: its runs (and gravity task) running or queued when
        the pass began."""
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
                    self.run_finished(case, self.guesses_done.pop(guess))
                    continue
                if guess in self.guesses:  # a guess that came true, still running
                    case.n_guesses_used += 1
                    self.guesses.pop(guess).kind = TaskKind.RUN
                    n_pending += 1
                    continue
                key = case.key(srf)
                stored = stored_run(case.out_dir / run_file_name(srf), key, case.policy)
                if stored is not None:
                    case.reused(stored)
                    continue
                self.queue.append(Ticket(case, TaskKind.RUN, srf, key))
                n_pending += 1
            if planned:  # the decision the case's guesses were made for is taken: stop the unused ones
                self._cancel_guesses(case)
            if n_pending or not planned:
                break  # waiting for runs, or done
        if not n_pending:
            self._cancel_guesses(case)  # no decision left to guess ahead of
        return not n_pending

    def _cancel_guesses(self, case: CaseSearch) -> None:
        """Stop the case's guesses still running."""
        for (index, srf), ticket in list(self.guesses.items()):
            if index == case.index:
                self._stop(ticket)
                del self.guesses[(index, srf)]

    # ------------------------------------------------------------------ a pass over the cases
    def plan(self, active: list[CaseSearch]) -> list[CaseSearch]:
        """Ask the search of every active case with a gravity state that has something new to plan
        on; the cases decided (nothing of theirs running or queued)."""
        pending = self._pending()
        n_parallel = max(1, math.ceil(self.runner.n_workers / max(len(active), 1)))
        decided = []
        for case in active:  # a case whose search has learnt nothing new would ask for nothing new
            if case.gravity is None or case.error is not None:
                continue
            if case.plan_again or not pending[case.index] or case.planned_parallel != n_parallel:
                if self._plan(case, n_parallel, pending[case.index]):
                    decided.append(case)
        return decided

    def start_runs(self, active: list[CaseSearch]) -> None:
        """After :meth:`plan` (and the decided cases gone from ``active``): what can no longer move a
        knee stopped, the queue to free workers, guesses on the idle ones."""
        self._cancel_above_failures()
        self._dispatch()
        if active:
            self._guess(active)

    def _cancel_above_failures(self) -> None:
        """Stop the runs and guesses that can no longer move their case's knee: above a failed run,
        or above a run known to fail; their workers are free for runs that can."""
        for ticket in list(self.in_flight):
            if ticket.kind is TaskKind.GRAVITY or ticket.case.single_run or not ticket.case.search.above_failure(ticket.srf):
                continue
            self._stop(ticket)
            ticket.case.plan_again = True
            if ticket.kind is TaskKind.RUN:
                ticket.case.search.withdraw(ticket.srf)
            else:
                self.guesses.pop((ticket.case.index, ticket.srf), None)
        if any(not ticket.case.single_run for ticket in self.queue):
            for ticket in list(self.queue):
                if not ticket.case.single_run and ticket.case.search.above_failure(ticket.srf):
                    ticket.case.search.withdraw(ticket.srf)
                    ticket.case.plan_again = True
                    self.queue.remove(ticket)

    def failures_signalled(self, has_passed_failure) -> bool:
        """Tell each case's search which of its running runs have passed the failure displacement
        since the last look (``has_passed_failure(ticket)``, the runner's); whether any has."""
        news = False
        for ticket in list(self.in_flight):
            search = ticket.case.search
            if ticket.kind is not TaskKind.RUN or ticket.case.single_run or ticket.srf in search.failing:
                continue
            if has_passed_failure(ticket):
                search.passed_failure(ticket.srf)
                ticket.case.plan_again = True
                news = True
        return news

    def _dispatch(self) -> None:
        """Start queued runs on free workers, earlier cases and lower SRF first; a running guess is
        stopped when a queued run needs its worker.  The run of a case of one run (a realisation)
        may also wait on a busy worker, one per worker: nothing stops or reorders it, and the worker
        starts it without waiting for the client to hear of the last one."""
        n_workers = self.runner.n_workers
        self.queue.sort(key=lambda ticket: (ticket.case.index, ticket.srf))
        while self.queue:
            ahead = n_workers if self.queue[0].case.single_run else 0
            if len(self.in_flight) >= n_workers + ahead:
                guesses = [t for t in self.in_flight if t.kind is TaskKind.GUESS]
                if not guesses:
                    return
                self._stop(guesses[-1])
                self.guesses.pop((guesses[-1].case.index, guesses[-1].srf), None)
            self.start(self.queue.pop(0))

    def _guess(self, active: list[CaseSearch]) -> None:
        """Guesses on idle workers, for cases with one undecided run."""
        idle = self.runner.n_workers - len(self.in_flight) if not self.queue else 0
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
                ticket = Ticket(case, TaskKind.GUESS, srf, key)
                self.start(ticket)
                self.guesses[(case.index, srf)] = ticket
                case.n_guessed += 1
                idle -= 1
