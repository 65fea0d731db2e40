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
