"""Shared fixtures of the tests: the reference scenes (``verification.scenes``), one quickstart
study run shared by the FOS, ParaView and notebook tests, one run of the shipped strength sweep
shared by the sweep and notebook tests, and a separately started dask cluster on loopback."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from distributed import Client

from verification.scenes import beam_scene, column_scene
from workflows.cases import RunOptions
from workflows.study import load_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def make_beam():
    return beam_scene


@pytest.fixture
def make_column():
    return column_scene


def _shipped_study_run(tmp_path_factory, name: str):
    """(study, output folder, outcome) of ``studies/<name>.toml`` run once on 2 local workers."""
    out = tmp_path_factory.mktemp(name)
    study = load_study(REPO / "studies" / f"{name}.toml")
    return study, out, run_study(study, out, RunOptions(workers=2))


@pytest.fixture(scope="session")
def quickstart_run(tmp_path_factory):
    """studies/quickstart.toml run once through a local cluster of 2 worker processes:
    (study, output folder, FosOutcome)."""
    return _shipped_study_run(tmp_path_factory, "quickstart")


@pytest.fixture(scope="session")
def strength_sweep(tmp_path_factory):
    """studies/sweep_strength.toml (3 x 3 cases) run once on a local cluster of 2 workers:
    (study, output folder, SweepOutcome)."""
    return _shipped_study_run(tmp_path_factory, "sweep_strength")


@pytest.fixture
def separate_dask_cluster(tmp_path):
    """A ``dask scheduler`` and two ``dask worker`` processes (1 thread each) started on loopback
    as a user would start them; yields the scheduler's address, kills them afterwards."""
    with _separate_cluster(tmp_path) as (address, _):
        yield address


@pytest.fixture
def separate_dask_scheduler_file(tmp_path):
    """As :func:`separate_dask_cluster`, yielding the scheduler file the scheduler wrote (what a batch
    job hands the study: ``--scheduler FILE``)."""
    with _separate_cluster(tmp_path) as _:
        yield tmp_path / "scheduler.json"


@pytest.fixture
def separate_dask_workers(tmp_path):
    """As :func:`separate_dask_cluster`, yielding (the scheduler's address, the two worker processes,
    each the leader of its own process group)."""
    with _separate_cluster(tmp_path) as (address, processes):
        yield address, processes[1:]


@pytest.fixture
def separate_dask_processes(tmp_path):
    """As :func:`separate_dask_workers`, yielding (the scheduler's address, the scheduler's process,
    the two worker processes)."""
    with _separate_cluster(tmp_path) as (address, processes):
        yield address, processes[0], processes[1:]


@contextlib.contextmanager
def _separate_cluster(tmp_path):
    scheduler_file = tmp_path / "scheduler.json"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    processes = [subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
         "--no-dashboard", "--scheduler-file", str(scheduler_file)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, env=env,
    )]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.is_file() or not scheduler_file.read_text().strip():
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        for _ in range(2):
            processes.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-dashboard"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, cwd=tmp_path,
            ))
        with Client(address, timeout=60) as client:  # both workers joined: a test may kill them or time their joining
            client.wait_for_workers(2, timeout=120)
        yield address, processes
    finally:
        for process in processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()
