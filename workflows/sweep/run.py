"""Run a sweep: every case's gravity and SRF search on one dask cluster, then ``study.nc``.

1. The cases (:func:`workflows.study.reading.sweep_cases`) are checked before anything runs:
   each one's resolution, the memory of the largest.  Cases that would compute the same thing
   (equal :func:`case_key`, e.g. a swept field no stage uses) are computed once.
2. Each distinct case gets ``OUT/cases/<case>/`` with its study text ``case.toml``; its
   gravity state and runs are kept there exactly as a single study keeps them (reused by the
   next invocation while their keys hold), and its ``summary.nc`` is written as soon as its
   search is done (``workflows.fos.orchestration.conclude_case``, no figures).
3. The engine (:mod:`workflows.fos.engine`) runs all cases at once on the cluster: gravity
   tasks (one per gravity key: a strength sweep over an elastic gravity stage relaxes once),
   then each case's runs, with no barrier between cases.
4. ``OUT/study.nc`` (:mod:`workflows.sweep.results`) and the figures are written last: a sweep
   that stopped early leaves no ``study.nc`` (the one of an earlier invocation is removed at
   the start), and the same command resumes it.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

from spfem_core.warmup import warm_up
from workflows.fos.cluster import connect, dask_session
from workflows.fos.engine import CaseSearch, Engine, FosProgress
from workflows.fos.keys import case_key
from workflows.fos.orchestration import conclude_case
from workflows.fos.scales import check_resolution
from workflows.memory_guard import check_memory, estimated_particles
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, sweep_cases
from workflows.sweep.figures import draw_sweep_figures
from workflows.sweep.results import (
    CASE_TEXT_NAME,
    CASES_FOLDER,
    STUDY_FILE_NAME,
    CaseResult,
    case_result,
    diverged_result,
    study_dataset,
)


@dataclass
class SweepOutcome:
    """What a sweep did and found."""

    out_dir: Path
    study_path: Path  # OUT/study.nc
    cases: list[SweepCase]
    results: dict[str, CaseResult]  # by case id
    n_distinct: int
    runs_made: int  # SRF runs computed by this invocation
    runs_reused: int  # SRF runs read back from an earlier invocation
    gravity_computed: int  # gravity states relaxed by this invocation (cases sharing a gravity key share one)
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


def check_sweep(study: Study, processes: int, max_memory_bytes: float | None) -> list[SweepCase]:
    """The cases of a sweep, each checked as a strength-reduction study (StudyError, nothing written)."""
    cases = sweep_cases(study)
    for case in cases:
        try:
            check_resolution(case.study)
        except StudyError as error:
            raise StudyError("sweep", f"the case {case.case_id.replace('__', ', ')}: {error}") from None
    largest = max(cases, key=lambda case: estimated_particles(case.study))
    check_memory(largest.study, processes=processes, limit_bytes=max_memory_bytes)
    return cases


def run_sweep(
    study: Study,
    out_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    force: bool = False,
    progress: FosProgress | None = None,
    max_memory_bytes: float | None = None,
) -> SweepOutcome:
    """Every case of ``study.sweep`` (module doc); results under ``out_dir``.

    StudyError (nothing written) for a case that cannot run or a sweep the memory cannot hold."""
    cases = check_sweep(study, workers if not scheduler else 1, max_memory_bytes)
    progress = progress or FosProgress()
    wall_start, start_unix_s = time.perf_counter(), time.time()
    if scheduler:  # fail before any output when the cluster cannot be reached
        connect(scheduler).close()
    out_dir = Path(out_dir)
    study_path = out_dir / STUDY_FILE_NAME
    make_output_folder(out_dir / CASES_FOLDER)
    study_path.unlink(missing_ok=True)  # written again at the end; a stopped sweep must not show an old one

    first_of: dict[str, SweepCase] = {}  # case key -> the first case with it
    same_as: dict[str, str] = {}  # case id -> the case id whose computation it shares
    for case in cases:
        original = first_of.setdefault(case_key(case.study), case)
        same_as[case.case_id] = original.case_id
    distinct = list(first_of.values())
    searches = []
    for index, case in enumerate(distinct):
        folder = out_dir / CASES_FOLDER / case.case_id
        make_output_folder(folder)
        write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
        searches.append(CaseSearch(index, case.study, folder, label=case.case_id))

    results: dict[str, CaseResult] = {}
    quiet_case = dataclasses.replace(progress, message=lambda text: progress.message(text) if "warning" in text else None)

    def conclude(search: CaseSearch) -> None:
        if search.error:
            results[search.label] = diverged_result(search.error, search.n_particles)
            return
        outcome = conclude_case(search, quiet_case, {"gravity": search.gravity_wall_s}, wall_start, figures=False)
        results[search.label] = case_result(outcome)

    with dask_session(workers, scheduler) as session:  # the cluster starts in a thread meanwhile
        warm_up()  # the compiled loop in the disk cache before the first task: compiled once
        srf_start = time.perf_counter()
        Engine(session.client(), searches, progress, start_unix_s, conclude, force=force).run()
        srf_elapsed = time.perf_counter() - srf_start
        session.close(wait=False)  # the workers shut down while study.nc and the figures are made
    by_id = {case_id: results[original] for case_id, original in same_as.items()}
    dataset = study_dataset(study, cases, by_id, same_as, len(distinct))
    write_dataset(dataset, study_path)
    figures = draw_sweep_figures(out_dir, dataset) if study.output.figures else []
    runs_reused = sum(search.reused_runs for search in searches)
    runs_made = sum(len(search.runs) for search in searches) - runs_reused
    timings = {
        "cases_elapsed": srf_elapsed,
        "gravity_worker": sum(search.gravity_wall_s for search in searches),
        "srf_runs_worker": sum(r["wall_time_s"] for search in searches for r in search.runs.values()
                               if r.get("started_s") == r.get("started_s")),  # NaN: reused
        "total": time.perf_counter() - wall_start,
    }
    gravity_computed = sum(search.gravity_wall_s > 0.0 for search in searches)
    return SweepOutcome(out_dir, study_path, cases, by_id, len(distinct), runs_made, runs_reused, gravity_computed,
                        timings, figures)

