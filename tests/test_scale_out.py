"""The scale-out recipe of docs/cluster.md, as far as it runs on one machine: a scheduler and
workers started by hand from a scheduler file (as an HPC batch job or ``dask-mpi`` starts them),
the workers with ``NUMBA_CPU_NAME=generic`` and a numba cache of their own job, the study given
``--scheduler <file>``, and one worker killed mid-study."""

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
import xarray as xr

REPO = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def batch_job(folder: Path, n_workers: int):
    """A scheduler writing ``folder/scheduler.json`` and ``n_workers`` workers (1 thread each) that
    find it through the file, with the environment the recipe sets; yields (the file, the worker
    processes, the environment), kills them all afterwards."""
    scheduler_file = folder / "scheduler.json"
    env = dict(os.environ, NUMBA_CPU_NAME="generic", SPFEM_CACHE_DIR=str(folder / "numba-cache"),
               DASK_DISTRIBUTED__WORKER__DAEMON="False")
    processes = [subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
         "--no-dashboard", "--scheduler-file", str(scheduler_file)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, env=env)]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.is_file() or not scheduler_file.read_text().strip():
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.1)
        processes += [subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(scheduler_file),
             "--nthreads", "1", "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, cwd=folder, env=env)
            for _ in range(n_workers)]
        yield scheduler_file, processes[1:], env
    finally:
        for process in processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()


@pytest.mark.slow  # about 110 s: the default suite runs a sweep through a scheduler file (test_sweep.py) and a
# worker killed mid-study (test_probabilistic.py); this one adds the job's own cache, compiled from nothing
def test_a_sweep_through_a_scheduler_file_survives_a_killed_worker(strength_sweep, tmp_path):
    """The shipped 3 x 3 strength sweep on the batch job above, one of its two workers killed once
    three cases are done: the scheduler runs the lost run again on the other, and every case's FOS,
    bracket and status equal the local run's (generic machine code rounds a few last bits
    differently, which moves no verdict)."""
    _, local_out, _ = strength_sweep
    out = tmp_path / "out"
    with batch_job(tmp_path, 2) as (scheduler_file, workers, env):
        process = subprocess.Popen(
            [sys.executable, "-m", "workflows.cli", str(REPO / "studies" / "sweep_strength.toml"), "--out", str(out),
             "--scheduler", str(scheduler_file), "--quiet"],
            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        deadline = time.monotonic() + 300
        while len(list(out.glob("cases/*/summary.nc"))) < 3:
            assert process.poll() is None and time.monotonic() < deadline, "the study ended before the kill"
            time.sleep(0.05)
        os.killpg(workers[0].pid, signal.SIGKILL)
        assert len(list(out.glob("cases/*/summary.nc"))) < 9  # killed mid-study
        stdout, stderr = process.communicate(timeout=300)
    assert process.returncode == 0, stderr
    assert stderr == "", stderr
    assert stdout.splitlines()[0].split()[:3] == ["cohesion_pa", "friction_deg", "FOS"]
    local, remote = xr.load_dataset(local_out / "study.nc"), xr.load_dataset(out / "study.nc")
    for name in ("fos", "fos_low", "fos_high", "knee_srf", "status", "n_particles"):
        assert (remote[name].values == local[name].values).all(), name
    assert list((tmp_path / "numba-cache").iterdir()), "the workers compiled into the job's own cache"


def test_a_scheduler_file_that_is_not_one_is_named(tmp_path):
    study = REPO / "studies" / "quickstart.toml"
    for content, expected in (("", "not a dask scheduler file"), (json.dumps({"type": "Scheduler"}),
                                                                  "not a dask scheduler file")):
        (tmp_path / "scheduler.json").write_text(content)
        run = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", str(tmp_path / "out"),
                              "--scheduler", str(tmp_path / "scheduler.json")], capture_output=True, text=True,
                             cwd=REPO)
        assert run.returncode == 2 and run.stderr.count("\n") == 1 and expected in run.stderr, run.stderr
    run = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", str(tmp_path / "out"),
                          "--scheduler", str(tmp_path / "missing.json")], capture_output=True, text=True, cwd=REPO)
    assert run.returncode == 2 and "cannot read the scheduler file" in run.stderr, run.stderr
    assert not (tmp_path / "out").exists()
