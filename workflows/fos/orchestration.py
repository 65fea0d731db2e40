"""A strength-reduction study, from study file to factor of safety.

1. **Gravity** (``workflows.fos.gravity``): the stages before the ``strength_reduction``
   stage run once, in this process while the cluster starts, stored as ``gravity.nc``,
   reused while their key holds.
2. Meanwhile one worker compiles the single-thread step the runs use, or loads it from the
   disk cache (``workflows.fos.cluster.DaskSession``): a gravity stage on threads compiled
   only the threaded one.
3. **SRF runs** are dask tasks on the cluster of ``workflows.fos.cluster``, chosen by the
   case's search and kept on disk (``workflows.fos.engine``, ``workflows.fos.run_store``).
4. :func:`conclude_case` writes ``OUT/summary.nc`` (``workflows.fos.summary``), then the figures.

A sweep (``workflows.sweep``) runs many such cases through the same engine.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from workflows.fos.cluster import connect, dask_session
from workflows.fos.criterion import brackets_agree, status_bracket
from workflows.fos.engine import CaseSearch, Engine, FosProgress
from workflows.fos.figures import draw_figures
from workflows.fos.gravity import gravity_state
from workflows.fos.report import verdict_line
from workflows.fos.run_store import SUMMARY_NAME
from workflows.fos.scales import check_resolution
from workflows.fos.summary import summary_dataset
from workflows.fos.verdict import displacement_floor_m
from workflows.memory_guard import check_memory
from workflows.output.writing import write_dataset
from workflows.study import Study, StudyError

__all__ = ["FosOutcome", "FosProgress", "conclude_case", "run_fos_study"]


@dataclass
class FosOutcome:
    """What a strength-reduction study (or one case of a sweep) did and found."""

    out_dir: Path
    summary_path: Path
    fos: float
    fos_low: float
    fos_high: float
    criterion: str
    knee_srf: float  # SRF of maximum curvature of the sweep (NaN: no knee)
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


def check_fos_study(study: Study, processes: int, max_memory_bytes: float | None) -> None:
    """The checks of a strength-reduction study before anything runs (StudyError, nothing written)."""
    if study.strength_reduction is None:
        raise StudyError("stages", "the last stage is not a strength_reduction stage")
    check_resolution(study)
    check_memory(study, processes=processes, limit_bytes=max_memory_bytes)


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
    check_fos_study(study, 1 + (0 if scheduler else workers), max_memory_bytes)
    progress = progress or FosProgress()
    out_dir = Path(out_dir)
    wall_start = time.perf_counter()
    start_unix_s = time.time()
    if scheduler:  # fail before any work when the cluster cannot be reached
        connect(scheduler).close()
    outcomes: list[FosOutcome] = []
    with dask_session(workers, scheduler, warm_up_worker=True) as session:
        stress, plastic, reused, n_particles, gravity_s = gravity_state(study, out_dir, force=force, progress=progress)
        case = CaseSearch(0, study, out_dir, gravity=(stress, plastic), gravity_reused=reused,
                          gravity_wall_s=gravity_s, n_particles=n_particles)
        srf_start = time.perf_counter()

        def conclude(case: CaseSearch) -> None:
            session.close(wait=False)  # the workers shut down while the summary and figures are made
            timings = {"gravity": gravity_s, "srf_runs_elapsed": time.perf_counter() - srf_start}
            outcomes.append(conclude_case(case, progress, timings, wall_start, figures=study.output.figures))

        Engine(session.client(), [case], progress, start_unix_s, conclude, force=force).run()
    return outcomes[0]


def conclude_case(case: CaseSearch, progress: FosProgress, timings: dict, wall_start: float,
                  figures: bool) -> FosOutcome:
    """The FOS and its report from a case's runs: messages, ``summary.nc`` and (``figures``) the figures."""
    study, out_dir, search, runs = case.study, case.out_dir, case.search, case.runs
    if case.reused_runs:
        progress.message(case.say(f"{case.reused_runs} SRF runs reused from {out_dir} "
                                  "(finished by an earlier invocation)"))
    if case.n_guessed:
        progress.message(case.say(
            f"{case.n_guessed} runs started ahead of the search on idle workers, {case.n_guesses_used} of them "
            "used (the others were stopped or left out of the answer)"
        ))
    by_reason: dict[str, list[float]] = {}
    for srf, reason in sorted(search.skipped.items()):
        if srf not in runs:
            by_reason.setdefault(reason, []).append(srf)
    for reason, values in by_reason.items():
        progress.message(case.say(f"SRF {', '.join(f'{f:g}' for f in values)} not run: {reason}"))

    stage = study.strength_reduction
    floor_m = displacement_floor_m(study)
    ordered = [runs[f] for f in sorted(runs)]
    timings = {"gravity": 0.0, "srf_runs_elapsed": 0.0, **timings, "io": case.io_s,
               "srf_runs_worker": float(sum(r["wall_time_s"] for r in ordered)),
               "remeshing": float(sum(r["remesh_wall_s"] for r in ordered))}
    knee = search.knee()
    status = status_bracket([r["srf"] for r in ordered], [r["status"] for r in ordered])
    agree = brackets_agree(knee, status, stage.fos_tolerance)
    outcome = FosOutcome(
        out_dir=out_dir, summary_path=out_dir / SUMMARY_NAME, fos=knee.fos, fos_low=knee.fos_low,
        fos_high=knee.fos_high, criterion=knee.reason, knee_srf=knee.knee_srf, status_low=status.fos_low, status_high=status.fos_high,
        criteria_agree=agree, non_monotone=list(status.non_monotone),
        verdict=verdict_line(knee, status, agree, ordered, stage), runs=ordered,
        skipped={f: r for f, r in search.skipped.items() if f not in runs}, gravity_reused=case.gravity_reused,
        timings_s=timings, n_particles=case.n_particles, guesses=(case.n_guessed, case.n_guesses_used),
    )
    io_start = time.perf_counter()
    summary = summary_dataset(study, outcome, knee, status, search.stop_reason, floor_m)
    timings["total"] = time.perf_counter() - wall_start
    summary.attrs.update({f"time_{name}_s": value for name, value in timings.items()})
    write_dataset(summary, outcome.summary_path)
    timings["io"] += time.perf_counter() - io_start
    if figures:
        outcome.figures = draw_figures(out_dir, summary)
    return outcome
