"""Faults under a running study (issue #29): the cluster's scheduler or workers lost, signals to the
whole process group.  Each ends in one line on stderr, the exit code of the README's table, the
finished runs kept, and the same command resumes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import pytest
from test_fos_study import REPO, SLOWER_QUICKSTART, cli, kill_group, start_study, wait_for_run_files

from workflows.cases import RunOptions
from workflows.fos import cluster
from workflows.study import parse_study
from workflows.study_types import run_study


def _rerun_reuses(study_path, out, finished: int, *options) -> None:
    rerun = cli(study_path, "--out", out, *options)
    assert rerun.returncode == 0, rerun.stderr
    reused = [line for line in rerun.stderr.splitlines() if "SRF runs reused" in line]
    assert reused and int(reused[0].split()[0]) >= finished, rerun.stderr


def test_a_killed_scheduler_ends_the_study_in_one_line_and_a_rerun_resumes(separate_dask_processes, tmp_path):
    """Before: 186 lines of dask tracebacks (FuturesCancelledError: scheduler-connection-lost), exit 1."""
    address, scheduler, workers = separate_dask_processes
    process, out, log = start_study(tmp_path, "log", "--scheduler", address)
    try:
        wait_for_run_files(process, out, log, 2)
        os.killpg(scheduler.pid, signal.SIGKILL)
        assert process.wait(timeout=120) == 2, log.read_text()
    finally:
        kill_group(process)
    errors = [line for line in log.read_text().splitlines() if "━" not in line]
    assert len(errors) == 1, errors
    assert f"lost the connection to the scheduler at {address}" in errors[0]
    assert "the finished runs are kept" in errors[0] and not list(out.glob("*.tmp"))
    _rerun_reuses(tmp_path / "quickstart.toml", out, 2, "--workers", "2")


def test_a_cluster_left_without_workers_ends_the_study(separate_dask_workers, tmp_path, monkeypatch):
    """Before: with every worker of ``--scheduler`` killed the study waited for one forever."""
    monkeypatch.setattr(cluster, "SCHEDULER_WORKER_WAIT_S", 2.0)
    address, workers = separate_dask_workers
    out = tmp_path / "out"

    def kill_the_workers():
        while len(list(out.glob("srf_*.nc"))) < 2:
            time.sleep(0.05)
        for worker in workers:
            os.killpg(worker.pid, signal.SIGKILL)

    killer = threading.Thread(target=kill_the_workers, daemon=True)
    killer.start()
    with pytest.raises(cluster.ClusterLost, match=f"the workers of the scheduler at {address} were lost"):
        run_study(parse_study(SLOWER_QUICKSTART), out, RunOptions(scheduler=address))
    killer.join(timeout=1)
    assert len(list(out.glob("srf_*.nc"))) >= 2 and not list(out.glob("*.tmp"))


CTRL_C_IN_A_CALLBACK = """
import gc, signal, sys, time
import workflows.study_types

def ctrl_c_in_a_callback(phase, info):  # as a Ctrl-C that lands while numba's llvmlite callbacks run
    gc.callbacks.remove(ctrl_c_in_a_callback)
    signal.raise_signal(signal.SIGINT)

def study_cut_short(*args, **kwargs):
    gc.callbacks.append(ctrl_c_in_a_callback)
    gc.collect()
    for _ in range(100):  # the study goes on, as numba did
        time.sleep(0.05)
    raise RuntimeError("no compiled object yet")  # what numba then said of the callback it lost

workflows.study_types.run_study = study_cut_short
from workflows.cli import run
sys.argv = ["spfem-fos", sys.argv[1], "--out", sys.argv[2]]
run()
"""


def test_ctrl_c_inside_a_callback_still_interrupts_in_one_line(tmp_path):
    """A KeyboardInterrupt raised in a callback of C code cannot leave it.  Before: "Exception
    ignored in ..." with its traceback, then the study ran on (or numba's RuntimeError, exit 1)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as at a terminal (module doc of test_fos_study)
    try:
        done = subprocess.run([sys.executable, "-c", CTRL_C_IN_A_CALLBACK, REPO / "studies" / "quickstart.toml",
                               tmp_path / "out"], capture_output=True, text=True, cwd=REPO, timeout=120)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert done.returncode == 130, done.stderr
    assert done.stderr.splitlines() == [f"interrupted: the finished SRF runs are kept in {tmp_path / 'out'}; run the "
                                        "same command again to resume"], done.stderr


def test_sigterm_to_the_process_group_ends_without_a_leaked_semaphore_warning(tmp_path):
    """``kill -TERM -PGID`` reaches the local workers and their forkserver too.  Before: exit 143 and
    "resource_tracker: There appear to be 2 leaked semaphore objects" (numba's process lock in each
    worker killed by the signal)."""
    process, out, log = start_study(tmp_path, "log")
    try:
        wait_for_run_files(process, out, log, 2)
        os.killpg(process.pid, signal.SIGTERM)
        assert process.wait(timeout=120) == 143
    finally:
        kill_group(process)
    lines = [line for line in log.read_text().splitlines() if "━" not in line]
    assert lines == [f"terminated (SIGTERM): the finished SRF runs are kept in {out}; run the same command again to "
                     "resume"], lines
    _rerun_reuses(tmp_path / "quickstart.toml", out, 2, "--workers", "2")
