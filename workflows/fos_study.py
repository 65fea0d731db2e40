"""A strength-reduction study, from study file to factor of safety.

1. **Gravity** (the stages before the ``strength_reduction`` stage) runs once, in this
   process, and is stored as ``OUT/<stage>.nc`` (``gravity.nc``).  Its files carry a key
   over everything that shapes that state (geometry, materials, loads, supports, solver,
   those stages, the core's sources); a later invocation with the same key reuses them.
2. The numba cache is warm by then (the gravity run compiled the loop, or
   :func:`spfem_core.warmup.warm_up` loads it), so workers start without compiling.
3. **SRF runs** are dask tasks (:func:`workflows.srf_run.run_srf`) on a local cluster of
   ``workers`` processes with one thread each, or on the cluster at ``scheduler``.  Which
   values to run comes from :class:`workflows.srf_search.SrfSearch`.  Each finished run is
   written by this process to ``OUT/srf_<F>.nc`` (temporary name, then rename) with a key
   over the gravity key, the stage and F: a rerun reuses it, and recomputes a damaged one.
4. ``OUT/summary.nc`` (coordinate ``srf``; scalar ``fos`` with ``fos_low``/``fos_high``)
   is written last, then the figures.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import logging
import math
import threading
import time
import uuid
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import xarray as xr

from workflows.fos_criterion import DIVERGED, FAILED, STABLE, brackets_agree, status_bracket
from workflows.results import interrupts_deferred, particle_stress, write_dataset
from workflows.srf_run import SrfRunResult, displacement_floor_m, failure_displacement_m, run_srf
from workflows.srf_search import RunOutcome, SrfSearch
from workflows.study import Study, StudyError

SEARCH_FIELDS = ("srf_min", "srf_max", "srf_step", "fos_tolerance", "max_runs")
"""Fields of the strength-reduction stage that choose which runs to make, not what a run does."""

SUMMARY_NAME = "summary.nc"


def run_file_name(srf: float) -> str:
    return f"srf_{srf:.4f}.nc"


def _digest(payload) -> str:
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def gravity_key(study: Study) -> str:
    """Hash of everything that shapes the gravity state (module doc)."""
    from spfem_core.jit import source_hash

    raw = dataclasses.asdict(study)
    for key in ("source_text", "output", "metrics"):
        raw.pop(key, None)
    raw["study"].pop("description", None)
    raw["stages"] = raw["stages"][:-1]
    raw["core"] = source_hash()
    return _digest(raw)


def run_key(study: Study, srf: float) -> str:
    """Hash of the gravity key, what a run does (not how the search picks runs) and F."""
    stage = dataclasses.asdict(study.strength_reduction)
    for key in SEARCH_FIELDS:
        stage.pop(key)
    return _digest({"gravity": gravity_key(study), "stage": stage, "srf": f"{srf:.4f}"})


@dataclass
class FosProgress:
    """Callbacks of a study run (all optional)."""

    stage: Callable[[str, float], None] = lambda name, fraction: None  # gravity stage progress
    runs: Callable[[int, int], None] = lambda done, planned: None  # SRF runs done / planned so far
    message: Callable[[str], None] = lambda text: None  # one line of news (reuse, skips, warnings)


@dataclass
class FosOutcome:
    """What :func:`run_fos_study` did and found."""

    out_dir: Path
    summary_path: Path
    fos: float
    fos_low: float
    fos_high: float
    criterion: str
    status_low: float
    status_high: float
    criteria_agree: bool
    verdict: str  # one line for the report
    runs: list[dict] = field(default_factory=list)  # per SRF: srf, max_displacement_m, status, ...
    skipped: dict[float, str] = field(default_factory=dict)
    gravity_reused: bool = False
    timings_s: dict[str, float] = field(default_factory=dict)
    n_particles: int = 0
    guesses: tuple[int, int] = (0, 0)  # runs started ahead of the search on idle workers, and used
    figures: list[Path] = field(default_factory=list)


# ------------------------------------------------------------------------------ gravity


def _gravity_paths(study: Study, out_dir: Path) -> list[Path]:
    return [out_dir / f"{stage.name}.nc" for stage in study.stages[:-1]]


def _read_gravity(path: Path, key: str):
    """(stress (n, 4), plastic strain (n,)) from a gravity file with this key, else None."""
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            if ds.attrs.get("gravity_key") != key:
                return None
            return particle_stress(ds), ds["particle_plastic_strain"].values.copy()
    except (OSError, KeyError, ValueError, RuntimeError):
        return None


def gravity_state(study: Study, out_dir: Path, *, force: bool, progress: FosProgress):
    """Run (or reuse) the stages before the strength reduction; (stress, plastic strain, reused, n, wall s)."""
    from workflows.runner import new_simulation, run_and_write_stage
    from workflows.scene_builder import build_scene, monitor_particles

    key = gravity_key(study)
    paths = _gravity_paths(study, out_dir)
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene)
    if not force and all(path.is_file() for path in paths):
        state = _read_gravity(paths[-1], key)
        if state is not None and state[0].shape == (scene.n_particles, 4):
            progress.message(f"gravity state reused from {paths[-1]} (its inputs are unchanged)")
            return state[0], state[1], True, scene.n_particles, 0.0
    out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    for index, (stage, path) in enumerate(zip(study.stages[:-1], paths)):
        report = lambda fraction, name=stage.name: progress.stage(name, fraction)  # noqa: E731
        series = run_and_write_stage(study, sim, index, path, monitors, out_dir, progress=report,
                                     attrs={"gravity_key": key})
        if series.converged is False:
            progress.message(f"warning: stage {stage.name!r} reached max_duration_s before converging")
    return sim.node_stress_pa.copy(), sim.node_plastic_strain.copy(), False, scene.n_particles, time.perf_counter() - start


# ------------------------------------------------------------------------------ runs on disk


_RESULT_SCALARS = ("status", "status_reason", "max_displacement_m", "final_kinetic_energy_j_per_m", "stop_time_s",
                   "wall_time_s", "remesh_wall_s", "n_steps")


def _stored_run(path: Path, key: str) -> dict | None:
    """The scalars of a finished run file with this key; None if missing, stale or damaged."""
    if not path.is_file():
        return None
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            attrs = dict(ds.attrs)
            _ = ds["max_displacement"].values  # a damaged file fails here
    except (OSError, KeyError, ValueError, RuntimeError):
        path.unlink(missing_ok=True)  # damaged: recompute
        return None
    if attrs.get("run_key") != key:
        return None
    # made by an earlier invocation: no start and end in this one
    return {name: attrs[f"run_{name}"] for name in _RESULT_SCALARS} | {
        "srf": float(attrs["srf"]), "started_s": math.nan, "finished_s": math.nan,
    }


def _run_scalars(result: SrfRunResult, study_start_unix_s: float) -> dict:
    """The scalars of a run made now, with its start and end on the worker in s since the study started."""
    return {name: getattr(result, name) for name in _RESULT_SCALARS} | {
        "srf": result.srf,
        "started_s": result.started_unix_s - study_start_unix_s,
        "finished_s": result.finished_unix_s - study_start_unix_s,
    }


def _write_run(result: SrfRunResult, path: Path, key: str, gkey: str) -> None:
    ds = result.dataset
    ds.attrs.update({f"run_{name}": getattr(result, name) for name in _RESULT_SCALARS})
    ds.attrs.update(run_key=key, gravity_key=gkey)
    write_dataset(ds, path)


def _remove_stale_runs(out_dir: Path, gkey: str) -> int:
    """Delete run files of another gravity state (another slope or another core)."""
    removed = 0
    for path in out_dir.glob("srf_*.nc"):
        try:
            with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
                stale = ds.attrs.get("gravity_key") != gkey
        except (OSError, ValueError, RuntimeError):
            stale = True
        if stale:
            path.unlink(missing_ok=True)
            removed += 1
    for path in out_dir.glob("*.nc.tmp"):
        path.unlink(missing_ok=True)
    return removed


# ------------------------------------------------------------------------------ dask


def connect(scheduler: str):
    """A client of the dask scheduler at ``scheduler``; StudyError (exit 2) if it cannot be reached."""
    from distributed import Client

    try:
        return Client(scheduler, timeout="30s")
    except (OSError, TimeoutError, ValueError) as error:
        raise StudyError("--scheduler", f"cannot connect to {scheduler}: {error}") from None


WORKER_MODULES = ("spfem_core.simulation", "workflows.results", "workflows.scene_builder", "workflows.srf_run")
"""What an SRF run imports (about 1.1 s of CPU per process on top of ``distributed``)."""


def _prepare_local_worker() -> None:
    """On each local worker, ahead of its first task: import :data:`WORKER_MODULES` (already
    done where the worker was forked from a preloaded server, see :func:`_worker_start_method`).
    (Lowering the workers' priority instead was tried: gravity gained 1-3 s, but any other
    program on the machine then starved the workers, up to tenfold.)"""
    for name in WORKER_MODULES:
        importlib.import_module(name)


def _worker_start_method() -> dict:
    """dask settings that start local workers by forking a server that has imported
    ``distributed`` and :data:`WORKER_MODULES` once (``forkserver``), where the platform
    has it; else {} (each worker is a fresh interpreter that imports them itself, ``spawn``).

    The workers start while this process compiles and runs the gravity stage, on the same
    cores.  Spawned, every worker imports everything (about 1.6 s of CPU each), so a second
    worker cost the gravity stage about 0.9 s of wall time on 2 cores, and started the
    runs that much later than one worker did.  Forked from the server, the imports are made
    once whatever the number of workers."""
    import multiprocessing

    import dask
    from distributed.utils import get_mp_context

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return {}
    settings = {"distributed.worker.multiprocessing-method": "forkserver"}
    with dask.config.set(settings):
        context = get_mp_context()  # distributed sets its own preload list here, once per process
    context.set_forkserver_preload(["distributed", *WORKER_MODULES])
    return settings


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
benchmarks/bench_fos.py --warm --workers 2``).  The nannies still check memory every second.

The active memory manager is off: every 2 s it drops all but one copy of data held by
several workers, such as the study and gravity state every run needs, which are scattered
to every worker.  Runs then went to the worker that kept the copy even while it was busy,
and queued there while the other worker idled (6.4 s of one study).  Work stealing stays
on as the remedy for any such placement."""


def _start_client(workers: int, scheduler: str | None):
    """A client on ``scheduler``, or on a new local cluster of ``workers`` single-thread
    processes (settings :data:`LOCAL_CLUSTER_CONFIG`), prepared by
    :func:`_prepare_local_worker`; (client, cluster or None)."""
    import dask
    from distributed import Client, LocalCluster

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
        _close_client(client, cluster)
        raise
    return client, cluster


def _close_client(client, cluster) -> None:
    """Bounded, so that an interrupted study still exits."""
    client.close(timeout=10)
    if cluster is not None:
        cluster.close(timeout=10)


class DaskSession:
    """The study's dask client, started in a thread so that the cluster starts and its workers
    import while this process runs the gravity stage, and closed in a thread so that the
    workers shut down while the summary and figures are made."""

    def __init__(self, workers: int, scheduler: str | None):
        from concurrent.futures import ThreadPoolExecutor

        pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="dask-start")
        self._starting = pool.submit(_start_client, workers, scheduler)
        pool.shutdown(wait=False)
        self._closing: threading.Thread | None = None

    def client(self):
        """The client, once started (a start error is raised here)."""
        return self._starting.result()[0]

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
        _close_client(client, cluster)


@contextmanager
def dask_session(workers: int, scheduler: str | None):
    """A :class:`DaskSession`, closed on the way out whatever happened meanwhile."""
    session = DaskSession(workers, scheduler)
    try:
        yield session
    finally:
        session.close(wait=True)


# ------------------------------------------------------------------------------ the study


def run_fos_study(
    study: Study,
    out_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    force: bool = False,
    progress: FosProgress | None = None,
) -> FosOutcome:
    """Gravity once, SRF runs on dask, the FOS from the knee; everything written to ``out_dir``."""
    if study.strength_reduction is None:
        raise StudyError("stages", "the last stage is not a strength_reduction stage")
    progress = progress or FosProgress()
    out_dir = Path(out_dir)
    wall_start = time.perf_counter()
    start_unix_s = time.time()
    timings = {"gravity": 0.0, "srf_runs_elapsed": 0.0, "srf_runs_worker": 0.0, "remeshing": 0.0, "io": 0.0}

    if scheduler:  # fail before any work when the cluster cannot be reached
        connect(scheduler).close()
    with dask_session(workers, scheduler) as session:
        stress, plastic, reused, n_particles, timings["gravity"] = gravity_state(
            study, out_dir, force=force, progress=progress
        )
        gkey = gravity_key(study)
        out_dir.mkdir(parents=True, exist_ok=True)
        if force:
            for path in out_dir.glob("srf_*.nc"):
                path.unlink()
        removed = _remove_stale_runs(out_dir, gkey)
        if removed:
            progress.message(f"removed {removed} run files of another gravity state")
        if reused:
            from spfem_core.warmup import warm_up

            warm_up()  # load the compiled loop into the disk cache before the workers start
        srf_start = time.perf_counter()
        search, runs, reused_runs, pool = _run_search(
            study, out_dir, session.client(), (stress, plastic), progress, timings, start_unix_s
        )
        timings["srf_runs_elapsed"] = time.perf_counter() - srf_start
        session.close(wait=False)  # the workers shut down meanwhile
        return _conclude(study, out_dir, search, runs, reused_runs, pool, reused, n_particles, progress, timings,
                         wall_start)


def _conclude(study, out_dir, search, runs, reused_runs, pool, gravity_reused, n_particles, progress, timings,
              wall_start) -> FosOutcome:
    """The FOS and its report from the runs made: messages, ``summary.nc`` and the figures."""
    if reused_runs:
        progress.message(f"{reused_runs} SRF runs reused from {out_dir} (finished by an earlier invocation)")
    if pool.n_guessed:
        progress.message(
            f"{pool.n_guessed} runs started ahead of the search on idle workers, {pool.n_guesses_used} of them "
            "used (the others were stopped or left out of the answer)"
        )
    by_reason: dict[str, list[float]] = {}
    for srf, reason in sorted(search.skipped.items()):
        if srf not in runs:
            by_reason.setdefault(reason, []).append(srf)
    for reason, values in by_reason.items():
        progress.message(f"SRF {', '.join(f'{f:g}' for f in values)} not run: {reason}")

    stage = study.strength_reduction
    floor_m = displacement_floor_m(study)
    ordered = [runs[f] for f in sorted(runs)]
    timings["srf_runs_worker"] = float(sum(r["wall_time_s"] for r in ordered))
    timings["remeshing"] = float(sum(r["remesh_wall_s"] for r in ordered))
    knee = search.knee()
    status = status_bracket([r["srf"] for r in ordered], [r["status"] for r in ordered])
    agree = brackets_agree(knee, status, stage.fos_tolerance)
    verdict = _verdict(knee, status, agree, ordered, stage)
    outcome = FosOutcome(
        out_dir=out_dir, summary_path=out_dir / SUMMARY_NAME, fos=knee.fos, fos_low=knee.fos_low,
        fos_high=knee.fos_high, criterion=knee.reason, status_low=status.fos_low, status_high=status.fos_high,
        criteria_agree=agree, verdict=verdict, runs=ordered,
        skipped={f: r for f, r in search.skipped.items() if f not in runs}, gravity_reused=gravity_reused,
        timings_s=timings, n_particles=n_particles, guesses=(pool.n_guessed, pool.n_guesses_used),
    )
    io_start = time.perf_counter()
    from workflows.fos_summary import summary_dataset

    summary = summary_dataset(study, outcome, knee, status, search.stop_reason, floor_m)
    timings["io"] += time.perf_counter() - io_start
    timings["total"] = time.perf_counter() - wall_start
    summary.attrs.update({f"time_{name}_s": value for name, value in timings.items()})
    write_dataset(summary, outcome.summary_path)
    if study.output.figures:
        from workflows.fos_figures import draw_figures

        outcome.figures = draw_figures(out_dir, summary)
    return outcome


@dataclass
class _Submissions:
    """The runs on the cluster: the ones the search asked for, and the guesses started on idle
    workers ahead of it (``srf_search`` module doc, step 3), kept apart until it asks for them.
    Every submission gets its own dask key and cancel event (with a token of this study, so
    that two studies on one scheduler keep apart), so a value cancelled once can be started
    again."""

    client: object
    study_futures: tuple
    token: str = field(default_factory=lambda: uuid.uuid4().hex[:12])
    asked: dict = field(default_factory=dict)  # future -> (srf, run key, cancel event name)
    guessed: dict = field(default_factory=dict)  # srf -> (future, run key, cancel event name)
    guessed_done: dict = field(default_factory=dict)  # srf -> (SrfRunResult, run key)
    n_submitted: int = 0
    n_guessed: int = 0
    n_guesses_used: int = 0

    def submit(self, srf: float, key: str):
        self.n_submitted += 1
        name = f"{key}-{self.token}-{self.n_submitted}"
        event = f"spfem-fos-cancel-{name}"
        future = self.client.submit(run_srf, *self.study_futures, srf, cancel_event=event, key=f"srf-{srf:.4f}-{name}",
                                    pure=False)
        return future, event

    def cancel(self, future, event: str) -> None:
        """Stop a run at its next check (its worker is free then) and forget it."""
        from distributed import Event

        Event(event, client=self.client).set()
        future.cancel()

    def futures(self) -> list:
        return list(self.asked) + [future for future, _, _ in self.guessed.values()]


def _run_search(study: Study, out_dir: Path, client, gravity, progress: FosProgress, timings: dict,
                start_unix_s: float) -> tuple[SrfSearch, dict[float, dict], int, _Submissions]:
    """Make the runs the search asks for on ``client`` (reusing finished files), and guesses on
    idle workers; write each run the search uses; (search, scalars per SRF, number of runs
    reused from disk, the submissions with their guess counts)."""
    from distributed import wait

    stage = study.strength_reduction
    gkey = gravity_key(study)
    n_parallel = max(1, sum(client.nthreads().values()))
    search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance,
                       displacement_floor_m(study), n_parallel=n_parallel, max_runs=stage.max_runs,
                       failure_m=failure_displacement_m(study))
    futures = tuple(client.scatter([item], broadcast=True)[0] for item in (study.source_text, *gravity))
    pool = _Submissions(client, futures)
    runs: dict[float, dict] = {}
    unwritten: list[tuple[SrfRunResult, str]] = []  # finished, written once the next runs are submitted
    reused_runs = 0

    def finished(result: SrfRunResult, key: str) -> None:
        runs[result.srf] = _run_scalars(result, start_unix_s)
        unwritten.append((result, key))
        search.finished(RunOutcome(result.srf, result.max_displacement_m, result.status))
        if result.status == DIVERGED:
            progress.message(f"warning: SRF {result.srf:g} diverged: {result.status_reason}")

    while True:
        planned = search.next_values()
        for srf in planned:
            search.started(srf)
            if srf in pool.guessed_done:  # a guess that came true, already finished
                pool.n_guesses_used += 1
                finished(*pool.guessed_done.pop(srf))
                continue
            if srf in pool.guessed:  # a guess that came true, still running
                pool.n_guesses_used += 1
                future, key, event = pool.guessed.pop(srf)
                pool.asked[future] = (srf, key, event)
                continue
            key = run_key(study, srf)
            stored = _stored_run(out_dir / run_file_name(srf), key)
            if stored is not None:
                runs[srf] = stored
                reused_runs += 1
                search.finished(RunOutcome(srf, stored["max_displacement_m"], stored["status"]))
                continue
            future, event = pool.submit(srf, key)
            pool.asked[future] = (srf, key, event)
        if planned:  # the decision the guesses were made for is taken: stop the ones not used
            for srf, (future, _, event) in list(pool.guessed.items()):
                pool.cancel(future, event)
                del pool.guessed[srf]
        io_start = time.perf_counter()
        for result, key in unwritten:  # the workers are busy with the next runs meanwhile
            _write_run(result, out_dir / run_file_name(result.srf), key, gkey)
        unwritten.clear()
        timings["io"] += time.perf_counter() - io_start
        ceiling = search.lowest_failed
        for future, (srf, key, event) in list(pool.asked.items()):
            if srf > ceiling:  # cannot change the answer: stop it, free its worker
                pool.cancel(future, event)
                del pool.asked[future]
                search.cancelled(srf, f"cancelled: above the failed SRF {ceiling:g}, cannot move the knee")
        for srf, (future, _, event) in list(pool.guessed.items()):
            if srf > ceiling:
                pool.cancel(future, event)
                del pool.guessed[srf]
        progress.runs(len(runs), len(runs) + len(pool.asked))
        if not pool.asked:
            if planned:
                continue  # every planned run was reused from disk or a finished guess: plan again
            break
        idle = n_parallel - len(pool.asked) - len(pool.guessed)
        known = set(pool.guessed) | set(pool.guessed_done)
        guesses = [f for f in search.speculative_values(idle + len(known)) if f not in known][:max(0, idle)]
        for srf in guesses:
            key = run_key(study, srf)
            if _stored_run(out_dir / run_file_name(srf), key) is not None:
                continue  # on disk already: reused when asked for
            future, event = pool.submit(srf, key)
            pool.guessed[srf] = (future, key, event)
            pool.n_guessed += 1
        done, _ = wait(pool.futures(), return_when="FIRST_COMPLETED")
        for future in done:
            if future in pool.asked:
                srf, key, _ = pool.asked.pop(future)
                finished(future.result(), key)  # a task's exception propagates: the study stops
                continue
            for srf, (guess, key, _) in list(pool.guessed.items()):
                if guess is future:
                    del pool.guessed[srf]
                    pool.guessed_done[srf] = (future.result(), key)
    for srf, (future, _, event) in pool.guessed.items():
        pool.cancel(future, event)
    pool.guessed.clear()
    progress.runs(len(runs), len(runs))
    return search, runs, reused_runs, pool


def _verdict(knee, status, agree, runs, stage) -> str:
    """One line: the FOS or why there is none, and any warning."""
    if not runs:
        return "no SRF run was made"
    failed_at_or_below_1 = [r["srf"] for r in runs if r["status"] == FAILED and r["srf"] <= 1.0]
    parts = []
    if math.isnan(knee.fos):
        if all(r["status"] == FAILED for r in runs if r["status"] != DIVERGED):
            parts.append(f"FOS < {runs[0]['srf']:g}: every run failed")
        elif all(r["status"] == STABLE for r in runs if r["status"] != DIVERGED):
            parts.append(f"FOS > {runs[-1]['srf']:g}: no run failed (raise srf_max)")
        else:
            parts.append(f"no FOS: {knee.reason}")
    else:
        parts.append(
            f"FOS = {knee.fos:.4g}, bracket [{knee.fos_low:.4g}, {knee.fos_high:.4g}] (steepest rise of the "
            f"displacement after the maximum-curvature knee at SRF {knee.knee_srf:g})"
        )
    if failed_at_or_below_1 or (not math.isnan(knee.fos) and knee.fos_high <= 1.0):
        parts.append("the slope is UNSTABLE AS BUILT (it fails at SRF <= 1)")
    if not agree:
        parts.append(f"WARNING: the run verdicts disagree ({status.reason})")
    elif status.non_monotone:
        parts.append(f"note: {status.reason}")
    return "; ".join(parts)
