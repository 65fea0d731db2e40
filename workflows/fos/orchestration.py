"""A strength-reduction study, from study file to factor of safety.

1. **Gravity** (``workflows.fos.gravity``): the stages before the ``strength_reduction``
   stage run once, in this process, stored as ``gravity.nc``, reused while their key holds.
2. The numba cache is warm by then (the gravity run compiled the loop, or
   :func:`spfem_core.warmup.warm_up` loads it), so workers start without compiling.
3. **SRF runs** are dask tasks (``workflows.fos.task.run_srf``) on the cluster of
   ``workflows.fos.cluster``.  Which values to run comes from ``workflows.fos.search.SrfSearch``;
   each finished run is written by this process (``workflows.fos.run_store``).
4. ``OUT/summary.nc`` (``workflows.fos.summary``) is written last, then the figures.
"""

from __future__ import annotations

import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from distributed import Event, wait

from spfem_core.warmup import warm_up
from workflows.fos.cluster import connect, dask_session
from workflows.fos.criterion import brackets_agree, status_bracket
from workflows.fos.figures import draw_figures
from workflows.fos.gravity import gravity_state
from workflows.fos.keys import gravity_key, run_key
from workflows.fos.report import verdict_line
from workflows.fos.run_store import (
    SUMMARY_NAME,
    remove_stale_runs,
    run_file_name,
    run_scalars,
    stored_run,
    write_run,
)
from workflows.fos.scales import check_resolution
from workflows.fos.search import RunOutcome, SrfSearch
from workflows.fos.summary import summary_dataset
from workflows.fos.task import SrfRunResult, run_srf
from workflows.fos.verdict import DIVERGED, displacement_floor_m, failure_displacement_m
from workflows.memory_guard import check_memory
from workflows.output.writing import make_output_folder, write_dataset
from workflows.study import Study, StudyError


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
    non_monotone: list[float]  # stable SRF values above a failed one (verdicts not monotone in F)
    verdict: str  # one line for the report
    runs: list[dict] = field(default_factory=list)  # per SRF: srf, max_displacement_m, status, ...
    skipped: dict[float, str] = field(default_factory=dict)
    gravity_reused: bool = False
    timings_s: dict[str, float] = field(default_factory=dict)
    n_particles: int = 0
    guesses: tuple[int, int] = (0, 0)  # runs started ahead of the search on idle workers, and used
    figures: list[Path] = field(default_factory=list)



def run_fos_study(
    study: Study,
    out_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    force: bool = False,
    progress: FosProgress | None = None,
    max_memory_bytes: float | None = None,
) -> FosOutcome:
    """Gravity once, SRF runs on dask, the FOS from the knee; everything written to ``out_dir``.

    StudyError (nothing written) when the particles would need more memory than
    ``max_memory_bytes`` (default: what the machine has available) in this process and the
    local workers (``memory_guard``)."""
    if study.strength_reduction is None:
        raise StudyError("stages", "the last stage is not a strength_reduction stage")
    check_resolution(study)
    check_memory(study, processes=1 + (0 if scheduler else workers), limit_bytes=max_memory_bytes)
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
        make_output_folder(out_dir)
        if force:
            for path in out_dir.glob("srf_*.nc"):
                path.unlink()
        removed = remove_stale_runs(out_dir, gkey)
        if removed:
            progress.message(f"removed {removed} run files of another gravity state")
        if reused:
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
    verdict = verdict_line(knee, status, agree, ordered, stage)
    outcome = FosOutcome(
        out_dir=out_dir, summary_path=out_dir / SUMMARY_NAME, fos=knee.fos, fos_low=knee.fos_low,
        fos_high=knee.fos_high, criterion=knee.reason, status_low=status.fos_low, status_high=status.fos_high,
        criteria_agree=agree, non_monotone=list(status.non_monotone), verdict=verdict, runs=ordered,
        skipped={f: r for f, r in search.skipped.items() if f not in runs}, gravity_reused=gravity_reused,
        timings_s=timings, n_particles=n_particles, guesses=(pool.n_guessed, pool.n_guesses_used),
    )
    io_start = time.perf_counter()
    summary = summary_dataset(study, outcome, knee, status, search.stop_reason, floor_m)
    timings["io"] += time.perf_counter() - io_start
    timings["total"] = time.perf_counter() - wall_start
    summary.attrs.update({f"time_{name}_s": value for name, value in timings.items()})
    write_dataset(summary, outcome.summary_path)
    if study.output.figures:
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
        Event(event, client=self.client).set()
        future.cancel()

    def futures(self) -> list:
        return list(self.asked) + [future for future, _, _ in self.guessed.values()]


def _run_search(study: Study, out_dir: Path, client, gravity, progress: FosProgress, timings: dict,
                start_unix_s: float) -> tuple[SrfSearch, dict[float, dict], int, _Submissions]:
    """Make the runs the search asks for on ``client`` (reusing finished files), and guesses on
    idle workers; write each run the search uses; (search, scalars per SRF, number of runs
    reused from disk, the submissions with their guess counts)."""
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
        runs[result.srf] = run_scalars(result, start_unix_s)
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
            stored = stored_run(out_dir / run_file_name(srf), key)
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
            write_run(result, out_dir / run_file_name(result.srf), key, gkey)
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
            if stored_run(out_dir / run_file_name(srf), key) is not None:
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


