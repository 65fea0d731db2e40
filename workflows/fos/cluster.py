"""The dask cluster an FOS study runs its SRF runs on: a local one, or one at ``--scheduler``.

The cluster starts in a thread (:class:`DaskSession`) while the study's process runs the
gravity stage, and closes in a thread while the summary and figures are made.
"""

from __future__ import annotations

import gc
import importlib
import json
import logging
import multiprocessing
import multiprocessing.forkserver
import signal
import socket
import threading
import time
import uuid
from concurrent.futures import CancelledError, ThreadPoolExecutor
from contextlib import contextmanager
from multiprocessing import resource_tracker
from pathlib import Path
from urllib.parse import urlsplit

import dask
from distributed import Client, KilledWorker, LocalCluster
from distributed.comm import CommClosedError
from distributed.utils import get_mp_context

from spfem_core.warmup import warm_up
from workflows.study import StudyError


def scheduler_address(scheduler: str) -> str:
    """The address ``scheduler`` names: itself, or the ``address`` held in the scheduler file it
    names (a path ending in ``.json``, as ``dask scheduler --scheduler-file``, ``dask-mpi`` and an
    HPC batch job write it on a shared file system); StudyError on ``--scheduler`` for a file
    without one."""
    if not scheduler.endswith(".json"):
        return scheduler
    try:
        address = json.loads(Path(scheduler).read_text(encoding="utf-8")).get("address")
    except OSError as error:
        raise StudyError("--scheduler", f"cannot read the scheduler file {scheduler}: {error.strerror or error} "
                         "(is the scheduler started, and the file on a file system this machine sees?)") from None
    except (ValueError, AttributeError):
        address = None
    if not isinstance(address, str) or not address:
        raise StudyError("--scheduler", f"{scheduler}: not a dask scheduler file (a JSON object with the "
                         "scheduler's \"address\")")
    return address


def connect(scheduler: str):
    """A client of the dask scheduler at ``scheduler`` (an address, or a scheduler file:
    :func:`scheduler_address`); StudyError (exit 2) if it cannot be reached.  A ``tcp://host:port``
    that refuses the connection is said at once (dask would retry it for the whole 30 s timeout)."""
    scheduler = scheduler_address(scheduler)
    address = urlsplit(scheduler if "://" in scheduler else f"tcp://{scheduler}")
    try:
        port = address.port
    except ValueError:
        raise StudyError("--scheduler", f"{scheduler}: not an address (tcp://host:8786)") from None
    if address.scheme == "tcp" and address.hostname and port:
        try:
            socket.create_connection((address.hostname, port), timeout=10).close()
        except OSError as error:
            raise StudyError("--scheduler", f"cannot connect to {scheduler}: {error.strerror or error} (is a dask "
                             "scheduler running there?)") from None
    try:
        return Client(scheduler, timeout="30s")
    except (OSError, TimeoutError, ValueError) as error:
        raise StudyError("--scheduler", f"cannot connect to {scheduler}: {error}") from None


SCHEDULER_WORKER_WAIT_S = 30.0
"""How long a study waits for a worker at ``--scheduler`` before it refuses to start, and, once
running, how long it waits for a worker to come back when every one is gone."""

WORKER_CHECK_S = 1.0
"""While runs are waited for, the client asks the scheduler this often whether it has a worker."""


class ClusterLost(ConnectionError):
    """The cluster can no longer run the study: its scheduler or every worker is gone.  The
    finished runs are on disk; the command says so as for any OSError under a study (exit 2)
    and the same command resumes once the cluster is back."""


def check_scheduler(scheduler: str) -> None:
    """StudyError (exit 2, nothing written) unless the scheduler at ``scheduler`` answers and has a
    worker within ``SCHEDULER_WORKER_WAIT_S``."""
    client = connect(scheduler)
    try:
        client.wait_for_workers(1, timeout=SCHEDULER_WORKER_WAIT_S)
    except (TimeoutError, OSError):
        raise StudyError("--scheduler", f"{scheduler} has no worker (none joined within "
                         f"{SCHEDULER_WORKER_WAIT_S:g} s): start one (dask worker "
                         f"{'--scheduler-file ' * scheduler.endswith('.json')}{scheduler}) or run without "
                         "--scheduler") from None
    finally:
        client.close()


WORKER_MODULES = ("spfem_core.simulation", "workflows.output.stage_file", "workflows.scene", "workflows.fos.task")
"""What an SRF run imports (about 1.1 s of CPU per process on top of ``distributed``)."""


def _prepare_local_worker() -> None:
    """On each local worker, ahead of its first task: import :data:`WORKER_MODULES` (already
    done where the worker was forked from a preloaded server, see :func:`_worker_start_method`),
    ignore SIGINT, and leave a failed task's traceback to the client.
    (Lowering the workers' priority instead was tried: gravity gained 1-3 s, but any other
    program on the machine then starved the workers, up to tenfold.)"""
    for name in WORKER_MODULES:
        importlib.import_module(name)
    # Ctrl-C at a terminal reaches the whole process group: the study's process stops the runs and
    # shuts the cluster down; a worker interrupted on its own would only print a traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # numba's threads take a process lock, a named semaphore registered with multiprocessing's
    # resource tracker, when this process's start method has "fork" in its name (forkserver does).
    # A worker stopped abruptly (its nanny kills one still compiling at shutdown) leaves it to the
    # tracker, which prints "leaked semaphore objects" as the study exits.  A worker starts no
    # process of its own: under spawn numba takes no lock.
    multiprocessing.set_start_method("spawn", force=True)
    # a task that raises (a diverged case of a sweep) reaches the client as its exception, which the
    # study reports in one line; the worker's own "Compute Failed" log would print its traceback
    logging.getLogger("distributed.worker").setLevel(logging.CRITICAL)


def _worker_start_method() -> dict:
    """dask settings that start local workers by forking a server that has imported
    ``distributed`` and :data:`WORKER_MODULES` once (``forkserver``), where the platform
    has it; else {} (each worker is a fresh interpreter that imports them itself, ``spawn``).

    The workers start while this process compiles and runs the gravity stage, on the same
    cores.  Spawned, every worker imports everything (about 1.6 s of CPU each), so a second
    worker cost the gravity stage about 0.9 s of wall time on 2 cores, and started the
    runs that much later than one worker did.  Forked from the server, the imports are made
    once whatever the number of workers."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return {}
    settings = {"distributed.worker.multiprocessing-method": "forkserver"}
    with dask.config.set(settings):
        context = get_mp_context()  # distributed sets its own preload list here, once per process
    context.set_forkserver_preload(["distributed", *WORKER_MODULES])
    _start_forkserver()
    return settings


def _start_forkserver() -> None:
    """Start the forkserver with SIGINT and SIGTERM blocked, as it and the workers it forks keep them.

    A signal to the study's process group (Ctrl-C at a terminal, ``kill -TERM -PGID``) is for
    the study's process, which stops the runs and shuts the cluster down.  A forkserver still
    importing its preloads died of Ctrl-C with a traceback (and the nannies logged that their
    workers failed to start); a worker killed by SIGTERM left its resources to the tracker's
    warning.  The resource tracker starts first: starting it unblocks both signals in the calling
    thread (it blocks them around its own start the same way)."""
    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


LOCAL_CLUSTER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.admin.tick.interval": "1s",
    "distributed.scheduler.active-memory-manager.start": False,
}
"""dask settings of the local cluster a study starts (not of a cluster at ``--scheduler``).

The defaults serve a dashboard this cluster does not have and many small tasks, where SRF
runs are few long ones started only on idle workers: a stack sample of every worker every
10 ms (profile), an event-loop tick every 20 ms and a memory check every 100 ms per worker
and per nanny.  On 2 cores with both busy, that upkeep ran in this process and the workers
at the runs' expense: with the defaults the runs of the reference slope took 77.9 s of
worker time on 2 workers, with these 72.6 s (69.2 s on 1 worker; ``python
-m benchmarks.bench_fos --warm --workers 2``).  The nannies still check memory every second.

The active memory manager is off: every 2 s it drops all but one copy of data held by
several workers, such as the gravity state every run needs, which is replicated to every
worker.  Runs then went to the worker that kept the copy even while it was busy,
and queued there while the other worker idled (6.4 s of one study).  Work stealing stays
on as the remedy for any such placement."""


class _RescheduledGather(logging.Filter):
    """Drops the client's warning "Couldn't gather N keys, rescheduling": a worker that held a
    finished run died before the run was fetched, and dask computes it again on another worker.
    Nothing is lost and the result is the same (tests/test_scale_out.py); the study would print
    dask's raw log line on stderr for it."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("Couldn't gather")


_RESCHEDULED_GATHER = _RescheduledGather()


def start_client(workers: int, scheduler: str | None):
    """A client on ``scheduler``, or on a new local cluster of ``workers`` single-thread
    processes (settings :data:`LOCAL_CLUSTER_CONFIG`), prepared by
    :func:`_prepare_local_worker`; (client, cluster or None)."""
    logging.getLogger("distributed.client").addFilter(_RESCHEDULED_GATHER)  # once: a filter is added once
    if scheduler:
        client = connect(scheduler)
        try:
            client.wait_for_workers(1, timeout=60)
        except BaseException:
            client.close()
            raise
        return client, None
    # the nannies hand the settings to their workers when they start them, here
    with dask.config.set({**LOCAL_CLUSTER_CONFIG, **_worker_start_method()}):
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
            # no dashboard, and the scheduler's health routes on a free port, not 8787: a second
            # study (or anything else on 8787) would otherwise get a warning
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            silence_logs=logging.ERROR,
        )
    client = Client(cluster)
    try:
        client.run(_prepare_local_worker)
    except BaseException:
        close_client(client, cluster)
        raise
    return client, cluster


def close_client(client, cluster) -> None:
    """Bounded, so that an interrupted study still exits.  The client's own log is silenced
    meanwhile: after a lost scheduler it logs the reconnection it gives up as an error with its
    traceback, where the study says what happened in one line."""
    client_log = logging.getLogger("distributed.client")
    level = client_log.level
    client_log.setLevel(logging.CRITICAL)
    try:
        client.close(timeout=10)
        if cluster is not None:
            cluster.close(timeout=10)
    finally:
        client_log.setLevel(level)


class DaskSession:
    """The study's dask client, started in a thread so that the cluster starts and its workers
    import while this process runs the gravity stage, and closed in a thread so that the
    workers shut down while the summary and figures are made.

    With ``warm_up_worker``, one worker compiles (or loads from the disk cache) the single-thread
    step the SRF runs use (:func:`spfem_core.warmup.warm_up`) as soon as the cluster is up, while
    this process compiles and runs the gravity stage: a gravity stage on threads compiles the
    threaded step only (``spfem_core.jit``), and on a cold cache the two compilations then run
    on two cores at once."""

    def __init__(self, workers: int, scheduler: str | None, warm_up_worker: bool = False):
        # HDF5 is not thread-safe: a netCDF file still open in unreachable objects would be closed by
        # whichever thread next collects garbage, the cluster's among them, while this one reads
        # the gravity file, and the process crashes (seen with datasets a caller left open).  They
        # are closed here, in this thread, before any other starts.
        gc.collect()
        pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="dask-start")
        self._starting = pool.submit(self._start, workers, scheduler, warm_up_worker)
        pool.shutdown(wait=False)
        self._closing: threading.Thread | None = None
        self._warming = None  # the warm-up task's future, kept: dask cancels a task nobody holds
        self.scheduler = scheduler
        self._next_worker_check = 0.0
        self._without_workers_since: float | None = None

    def _start(self, workers: int, scheduler: str | None, warm_up_worker: bool):
        client, cluster = start_client(workers, scheduler)
        if warm_up_worker:
            self._warming = client.submit(warm_up, pure=False, key=f"warm-up-{uuid.uuid4().hex[:12]}")
        return client, cluster

    def client(self):
        """The client, once started (a start error is raised here)."""
        return self._starting.result()[0]

    def where(self) -> str:
        """How messages name the cluster."""
        return f"the scheduler at {self.scheduler}" if self.scheduler else "the local cluster"

    def check_workers(self) -> None:
        """ClusterLost once the cluster has had no worker for ``SCHEDULER_WORKER_WAIT_S``: dask would
        wait for one forever (asks the scheduler at most every ``WORKER_CHECK_S``)."""
        now = time.monotonic()
        if now < self._next_worker_check:
            return
        self._next_worker_check = now + WORKER_CHECK_S
        if self.client().nthreads():
            self._without_workers_since = None
        elif self._without_workers_since is None:
            self._without_workers_since = now
        elif now - self._without_workers_since >= SCHEDULER_WORKER_WAIT_S:
            hint = f": start one (dask worker {self.scheduler})" if self.scheduler else ""
            raise ClusterLost(f"the workers of {self.where()} were lost (none for {SCHEDULER_WORKER_WAIT_S:g} s){hint}")

    def lost(self, error: BaseException) -> ClusterLost:
        """What dask raised when the scheduler, or a run's every worker, died, said in a line."""
        if isinstance(error, KilledWorker):
            return ClusterLost(f"the workers of {self.where()} died running {error.args[0]} (dask tried "
                               f"{error.args[2] + 1} of them)")
        return ClusterLost(f"lost the connection to {self.where()} (did it stop?)")

    def close(self, wait: bool) -> None:
        """Start closing (once); with ``wait``, wait for it (bounded)."""
        if self._closing is None:
            self._closing = threading.Thread(target=self._close, name="dask-close")
            self._closing.start()
        if wait:
            self._closing.join(timeout=60)

    def _close(self) -> None:
        try:
            client, cluster = self._starting.result(timeout=120)
        except BaseException:  # it never started: nothing to close
            return
        close_client(client, cluster)


@contextmanager
def dask_session(workers: int, scheduler: str | None, warm_up_worker: bool = False):
    """A :class:`DaskSession`, closed on the way out whatever happened meanwhile; the scheduler or
    the workers lost on the way: ClusterLost."""
    session = DaskSession(workers, scheduler, warm_up_worker)
    try:
        yield session
    except (CancelledError, CommClosedError, KilledWorker) as error:  # CancelledError: the futures of a lost scheduler
        raise session.lost(error) from None
    finally:
        session.close(wait=True)


