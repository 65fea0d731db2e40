"""The engine's dask futures (``workflows.fos.dask_runs``), without a cluster."""

from __future__ import annotations


def test_a_shared_state_with_no_worker_running_to_copy_it_to_is_kept_not_a_traceback(monkeypatch):
    """``client.replicate`` raises ValueError("Can not use replicate to delete data") when no worker is running at
    that moment (one lost, the others restarting: seen after a cluster's processes were stopped for minutes); the
    study ended in that traceback.  The state's future is kept: the runs fetch it, or dask makes it again."""
    from workflows.fos import dask_runs

    class Client:
        def submit(self, function, value, **_):
            return ("future", value)

        def replicate(self, futures):
            raise ValueError("Can not use replicate to delete data")

    monkeypatch.setattr(dask_runs, "wait", lambda futures: None)
    runs = dask_runs.DaskRuns(session=None)
    runs.client = Client()
    assert runs._on_every_worker("state", "gravity-state-x") == ("future", "state")


def test_a_result_lost_with_its_worker_and_no_worker_left_ends_the_study():
    """A task finished, then every worker was killed before its result was fetched: ``Future.result()`` waited
    forever (the suite hung in test_faults.py's cluster left without workers, a race on when the workers die).
    The fetch now asks the session about the workers while it waits: ClusterLost."""
    import pytest

    from workflows.fos import dask_runs
    from workflows.fos.cluster import ClusterLost

    class Lost:
        status = "finished"

        def result(self, timeout=None):
            raise TimeoutError  # the data is gone with its worker: dask waits for a worker to make it again

    class Session:
        calls = 0

        def check_workers(self):
            Session.calls += 1
            if Session.calls >= 3:
                raise ClusterLost("the workers of the scheduler at tcp://x were lost (none for 30 s)")

    runs = dask_runs.DaskRuns(session=Session())
    future, ticket = Lost(), object()
    runs.futures[future], runs.future_of[ticket] = ticket, future
    with pytest.raises(ClusterLost, match="were lost"):
        runs.result(ticket)
    assert Session.calls == 3
