"""The planner of many cases' SRF runs (``workflows.fos.planner``) driven without dask: a scripted
runner that finishes the tasks it was given oldest first, the slope's response a known curve that
fails above F* = 1.3712."""

from __future__ import annotations

import math

import pytest

from verification.study_text import (
    COARSE_SLOPE_M,
    drained_soil,
    gravity,
    gravity_stage,
    held_base_and_sides,
    srf_stage,
    study_text,
)
from workflows.fos.case_search import CaseSearch
from workflows.fos.planner import Planner, TaskKind
from workflows.fos.search import SrfSearch
from workflows.fos.task import RunRecord, SrfRunResult
from workflows.fos.verdict import FAILED, STABLE
from workflows.progress import Progress
from workflows.study import parse_study

F_STAR = 1.3712
TOLERANCE = 0.02
STUDY = parse_study(study_text(
    "planned", {"polygon_m": COARSE_SLOPE_M, "spacing_m": 1.0}, [drained_soil()],
    [gravity_stage(5.0, 0.1), srf_stage(1.0, 0.05, 1.0, 2.0, 0.1, fos_tolerance=TOLERANCE, max_runs=40)],
    loads=gravity(), boundary=held_base_and_sides(0.0)))


def response(srf: float) -> SrfRunResult:
    """5 mm growing gently with F below F*, 2 m (failed) above it."""
    failed = srf > F_STAR
    u_m = 2.0 if failed else 0.005 * math.exp(2.0 * (srf - 1.0))
    record = RunRecord(srf, FAILED if failed else STABLE, "scripted", u_m, 0.0, 1.0, 0.1, 0.0, 10)
    return SrfRunResult(record, started_unix_s=0.0, finished_unix_s=1.0)


class ScriptedRunner:
    """Starts what it is given, stops what it is told; its oldest task finishes first."""

    def __init__(self, n_workers: int):
        self.n_workers = n_workers
        self.running: list = []
        self.started: list[tuple[TaskKind, float]] = []
        self.runs_of: list[tuple[int, float]] = []  # (case index, srf) of every run started
        self.n_stopped = 0

    def start(self, ticket) -> None:
        self.running.append(ticket)
        self.started.append((ticket.kind, ticket.srf))
        if ticket.kind is TaskKind.RUN:
            self.runs_of.append((ticket.case.index, ticket.srf))

    def stop(self, ticket) -> None:
        self.running.remove(ticket)
        self.n_stopped += 1


def a_case(tmp_path, index: int) -> CaseSearch:
    case = CaseSearch(index, STUDY, tmp_path / f"case{index}")
    case.gravity = object()  # known: its search may run
    case.search = SrfSearch(1.0, 2.0, 0.1, TOLERANCE, 1e-3, max_runs=40, failure_m=1.0)
    return case


def drive(cases: list[CaseSearch], runner: ScriptedRunner) -> list[CaseSearch]:
    """The engine's loop without files or gravity: plan, start, one task back; the cases in the
    order they were decided."""
    planner = Planner(runner, Progress(), start_unix_s=0.0)
    decided: list[CaseSearch] = []
    for _ in range(200):
        active = [case for case in cases if case not in decided]
        decided += planner.plan(active)
        active = [case for case in cases if case not in decided]
        if not active:
            assert not planner.queue and not planner.guesses  # nothing left behind
            planner.stop_all()
            return decided
        planner.start_runs(active)
        if not runner.running:
            continue  # runs dropped from the queue above a failure: plan again
        ticket = runner.running.pop(0)
        assert planner.landed(ticket)
        if ticket.kind is TaskKind.RUN:
            planner.run_finished(ticket.case, response(ticket.srf))
        else:
            planner.guess_finished(ticket, response(ticket.srf))
    raise AssertionError("the planner never decided its cases")


def test_one_worker_runs_the_sweep_up_to_its_first_failure_then_splits_the_bracket(tmp_path):
    runner = ScriptedRunner(n_workers=1)
    [case] = drive([a_case(tmp_path, 0)], runner)
    # the sweep by 0.1 until 1.4 fails (1.5 .. 2.0 skipped); [1.3, 1.4] split in three (bisection would
    # need three halvings to reach the tolerance), both stable; [1.3667, 1.4] halved (one more): failed
    assert runner.started == [(TaskKind.RUN, f) for f in (1.0, 1.1, 1.2, 1.3, 1.4, 1.3333, 1.3667, 1.3834)]
    knee = case.search.knee()
    assert (knee.fos_low, knee.fos_high) == (1.3667, 1.3834)
    assert knee.fos_low <= F_STAR <= knee.fos_high
    assert sorted(case.runs) == sorted(f for _, f in runner.started)
    assert case.n_guessed == 0


@pytest.mark.parametrize("n_workers", [2, 3, 5])
def test_more_workers_guess_ahead_but_use_the_same_runs_and_fos(tmp_path, n_workers):
    one = drive([a_case(tmp_path / "one", 0)], ScriptedRunner(n_workers=1))[0]
    runner = ScriptedRunner(n_workers)
    [case] = drive([a_case(tmp_path / "many", 0)], runner)
    knee, knee_one = case.search.knee(), one.search.knee()
    assert (knee.fos, knee.fos_low, knee.fos_high) == (knee_one.fos, knee_one.fos_low, knee_one.fos_high)
    used = {srf for srf in case.runs if srf <= knee.fos_high}  # runs above the first failure depend on timing
    assert used == {srf for srf in one.runs if srf <= knee.fos_high}
    assert case.n_guessed > 0 and any(kind is TaskKind.GUESS for kind, _ in runner.started)


def test_earlier_cases_go_first_and_every_case_is_decided(tmp_path):
    runner = ScriptedRunner(n_workers=2)
    cases = [a_case(tmp_path, index) for index in range(3)]
    decided = drive(cases, runner)
    assert [case.index for case in decided] == [0, 1, 2]
    # one value per case at a time (2 workers, 3 cases): case 0's and case 1's first; case 2's waits in
    # the queue while case 0's second, asked for when its first is back, goes before it
    assert runner.runs_of[:4] == [(0, 1.0), (1, 1.0), (0, 1.1), (1, 1.1)]
    for case in cases:
        assert case.search.knee().fos_low <= F_STAR <= case.search.knee().fos_high
