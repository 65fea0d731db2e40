"""The engine's tasks as dask futures: started, stopped, waited for, their results fetched.

It decides nothing (``workflows.fos.planner`` does); it keeps, for each :class:`~workflows.fos.planner.Ticket`
in flight, its future and the two Events of a run: one the client sets to stop it, one the run sets
once its largest displacement has passed the failure displacement (``workflows.fos.task.run_srf``).
A case's gravity state and steady flow go to every worker once, as a task's result
(``fos.task.held``), shared by every run of the cases with that state or flow.
"""

from __future__ import annotations

import uuid

from distributed import Client, Event, Future, wait

from workflows.fos.case_search import has_flow
from workflows.fos.gravity import run_gravity
from workflows.fos.planner import TaskKind, Ticket
from workflows.fos.task import held, run_srf
from workflows.seepage.flow import flow_inputs

SIGNAL_POLL_S = 0.2
"""While waiting for a task, the client checks this often whether a running run has passed the
failure displacement: one scheduler round trip per running run."""


class DaskRuns:
    """The futures of the engine's tickets on the client of ``session`` (a
    ``workflows.fos.cluster.DaskSession``, asked for its client only at :meth:`connect`)."""

    def __init__(self, session) -> None:
        self.session = session
        self.client: Client | None = None
        self.n_workers = 1
        self.token = uuid.uuid4().hex[:12]
        self.n_submitted = 0
        self.futures: dict[Future, Ticket] = {}
        self.future_of: dict[Ticket, Future] = {}
        self.events: dict[Ticket, tuple[str, str]] = {}  # a run's (stop Event, failing Event) names
        self.scattered: dict = {}  # gravity key -> the future of that gravity state on every worker
        self.flows: dict = {}  # the inputs of a steady flow (seepage.flow.flow_inputs) -> its future on every worker
        self.shared: dict[int, tuple] = {}  # case index -> (study, gravity future, flow future) for its runs

    def connect(self) -> int:
        """The cluster's client; how many tasks it runs at once."""
        self.client = self.session.client()
        self.n_workers = max(1, sum(self.client.nthreads().values()))
        return self.n_workers

    def _submit(self, function, *args, priority: int, **kwargs):
        self.n_submitted += 1
        return self.client.submit(function, *args, priority=priority, pure=False, **kwargs)

    def start(self, ticket: Ticket) -> None:
        """A gravity task, or a run task.  A case that makes one run gets no Events: it has nothing to
        stop or plan on early, and each Event costs its run a scheduler round trip per stop-rule check."""
        case = ticket.case
        if ticket.kind is TaskKind.GRAVITY:
            future = self._submit(run_gravity, case.study.source_text, flow=case.flow, priority=1_000_000 - case.index,
                                  key=f"gravity-{case.gkey}-{self.token}-{case.index}")
        else:
            study, gravity, flow = self._shared(case)
            name = f"{ticket.key}-{self.token}-{self.n_submitted + 1}"
            event, failing = ("", "") if case.single_run else (f"spfem-fos-cancel-{name}", f"spfem-fos-failing-{name}")
            future = self._submit(run_srf, study, gravity, ticket.srf, cancel_event=event or None, run_key=ticket.key,
                                  gravity_key=case.gkey, failing_event=failing or None, policy=case.policy, flow=flow,
                                  key=f"srf-{ticket.srf:.4f}-{name}", priority=-case.index)
            self.events[ticket] = (event, failing)
        self.futures[future] = ticket
        self.future_of[ticket] = future

    def _shared(self, case) -> tuple:
        """(study, its gravity state's future, its flow's future or None), put on every worker once
        per gravity state and per flow, whatever the cases sharing them (the client's flow: the
        workers do not solve it again)."""
        if case.index not in self.shared:
            if case.gkey not in self.scattered:
                self.scattered[case.gkey] = self._on_every_worker(case.gravity, f"gravity-state-{case.gkey}")
            flow = None
            if has_flow(case.study):
                inputs = flow_inputs(case.study)
                if inputs not in self.flows:
                    self.flows[inputs] = self._on_every_worker(case.steady_flow(),
                                                               f"steady-flow-{case.gkey}-{len(self.flows)}")
                flow = self.flows[inputs]
            self.shared[case.index] = (case.study, self.scattered[case.gkey], flow)
        return self.shared[case.index]

    def _on_every_worker(self, value, name: str):
        """``value`` as a task's result replicated to every worker (``fos.task.held``)."""
        future = self.client.submit(held, value, pure=False, priority=2_000_000, key=f"{name}-{self.token}")
        wait([future])
        try:
            self.client.replicate([future])  # on every worker now: runs go wherever a worker is free
        except ValueError:  # no worker running at this moment (one lost, the others restarting): runs fetch it
            pass  # from the worker that holds it, or dask makes it again from its task, when they start
        return future

    def stop(self, ticket: Ticket) -> None:
        """Stop a run at its next check (its worker is free then) and forget it."""
        future = self.future_of.pop(ticket)
        del self.futures[future]
        event, _ = self.events.pop(ticket, ("", ""))
        if event:
            Event(event, client=self.client).set()
        future.cancel()

    def has_passed_failure(self, ticket: Ticket) -> bool:
        """Whether the run has set its failing Event."""
        _, failing = self.events.get(ticket, ("", ""))
        return bool(failing) and Event(failing, client=self.client).is_set()

    def wait(self, poll) -> list[Ticket]:
        """The tickets whose tasks finished, once one has; [] as soon as ``poll()`` says there is news
        to plan on (asked every :data:`SIGNAL_POLL_S`).  A cluster left without workers ends the study
        (``DaskSession.check_workers``): dask would wait for one forever."""
        while True:
            try:
                finished, _ = wait(list(self.futures), timeout=SIGNAL_POLL_S, return_when="FIRST_COMPLETED")
                return [self.futures[future] for future in finished]
            except TimeoutError:
                if poll():
                    return []
                self.session.check_workers()

    def result(self, ticket: Ticket):
        """The finished task's result (its exception raised), and the ticket forgotten.  A result lost with its
        worker before it was fetched is made again by dask on a worker left; with none left the study ends
        (``DaskSession.check_workers``), as in :meth:`wait`: dask would wait for one forever."""
        future = self.future_of.pop(ticket)
        del self.futures[future]
        self.events.pop(ticket, None)
        while True:
            try:
                return future.result(timeout=SIGNAL_POLL_S)
            except TimeoutError:
                if future.status == "error":  # (the task's own TimeoutError)
                    raise
                self.session.check_workers()

    def forget(self, case, gravity: bool, flow: bool) -> None:
        """A case handed back: its runs' shared values no longer kept for it; its gravity state and flow
        released on the workers when no other case needs them (``gravity``, ``flow``)."""
        self.shared.pop(case.index, None)
        if gravity:
            self.scattered.pop(case.gkey, None)
        if flow:
            self.flows.pop(flow_inputs(case.study), None)
