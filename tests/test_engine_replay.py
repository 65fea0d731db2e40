"""A resumed study's search fed its runs from disk (``fos.planner.Planner.replay``): runs a stopped or finished
invocation made are read back whenever the search asks for them, also beside a value it never ran because a
run below it failed first."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from workflows.fos import planner
from workflows.fos.case_search import CaseSearch
from workflows.fos.search import SrfSearch
from workflows.fos.task import RunRecord

# (srf, status, max displacement m) of a realisation of the undrained random-field study at h = 2 m, searched in
# the window (1.0261, 1.5625, 0.1341): the refinement asked for 1.4731 and 1.5178 together; 1.4731 failed
# first and 1.5178 was cancelled above it, never run
RUNS = [(1.0261, "stable", 0.0076), (1.1602, "stable", 0.0106), (1.2943, "stable", 0.0149),
        (1.4284, "stable", 0.037), (1.4358, "stable", 0.0485), (1.4377, "failed", 0.0531),
        (1.4396, "failed", 0.0587), (1.4433, "failed", 0.0736), (1.4582, "failed", 0.165),
        (1.4731, "failed", 0.2437), (1.5625, "failed", 0.6281)]


def _record(srf: float, status: str, displacement_m: float) -> RunRecord:
    return RunRecord(srf, status, "", displacement_m, 0.0, 5.0, 1.0, 0.0, 100)


@pytest.mark.parametrize("n_parallel", [1, 2])
def test_a_resumed_search_reads_back_every_run_beside_one_cancelled_above_a_failure(monkeypatch, n_parallel):
    """Every run the search asks for is on disk but 1.5178, asked beside 1.4731 and cancelled when 1.4731
    failed: the replay reads 1.4731, the search no longer asks for 1.5178, and the case concludes from disk
    (before: it stopped at the pair, and the study made runs again, or waited with no task running)."""
    on_disk = {srf: _record(srf, status, u) for srf, status, u in RUNS}
    monkeypatch.setattr(planner, "stored_run", lambda path, key, policy: on_disk.get(float(path.stem[4:])))
    search = SrfSearch(0.4, 2.0, 0.1, 0.002, 0.01, n_parallel=n_parallel, max_runs=40, failure_m=math.inf,
                       window=(1.0261, 1.5625, 0.1341))
    case = CaseSearch(index=0, study=None, out_dir=Path("/nonexistent"), search=search)
    case.key = lambda srf: ""  # the run key: any, stored_run is replaced
    host = planner.Planner(runner=None, progress=None, start_unix_s=0.0)
    assert host.replay(case)
    assert 1.5178 not in case.runs and case.reused_runs == len(RUNS)
    knee = search.knee()
    assert knee.fos_high - knee.fos_low <= 0.002 + 1e-9 and 1.4358 <= knee.fos_low < knee.fos_high <= 1.4377
