"""A sweep of a stage study (no strength reduction, e.g. a runout): every case's stages, then ``study.nc``.

1. The cases (:func:`workflows.study.reading.sweep_cases`) are checked before anything runs,
   and the memory of the largest.
2. Each case gets ``OUT/cases/<case>/`` with its study text ``case.toml`` and runs there exactly
   as a single study would (``workflows.stages.run_study``: stage files, snapshots, figures,
   animations), in this process, one case after another, each on all cores (the compiled step
   is threaded, ``spfem_core.jit``): no cluster starts, and ``--workers`` / ``--scheduler``,
   which place SRF runs, do not apply.  A case whose results are up to date with its text is
   not run again; a case that diverges is recorded as such and the sweep goes on.
3. ``OUT/study.nc`` (:func:`stage_sweep_dataset`): per case its folder, status and particles;
   every scalar runout metric of each runout stage over (<sweep dims>, ``runout_stage``); the
   collapse metrics of the last stage when the study has ``[metrics]``.  Written last: a sweep
   that stopped early leaves none, and the same command resumes it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.divergence import DivergenceError
from workflows.memory_guard import check_memory, estimated_particles
from workflows.output.stage_file import provenance, result_paths
from workflows.output.variables import COLLAPSE_METRICS, RUNOUT_METRICS, STAGE_SWEEP_FILE
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.stages import StageProgress, run_study
from workflows.study import RunoutStage, Study
from workflows.study.reading import SweepCase, sweep_cases
from workflows.sweep.results import CASE_TEXT_NAME, CASES_FOLDER, STUDY_FILE_NAME, sweep_coordinates

DONE, DIVERGED = "done", "diverged"


def _scalar_names(table) -> list[str]:
    return [name for name, variable in table.items() if variable.dims == ()]


RUNOUT_SCALARS = _scalar_names(RUNOUT_METRICS)
COLLAPSE_SCALARS = _scalar_names(COLLAPSE_METRICS)


@dataclass
class StageCaseResult:
    """What ``study.nc`` and the printed table hold of one case."""

    status: str  # DONE or DIVERGED
    message: str  # the divergence, or ""
    n_particles: int
    runout: dict[str, dict[str, float]]  # runout stage name -> scalar metric -> value
    collapse: dict[str, float]  # scalar collapse metric -> value (empty without [metrics])
    ran: bool  # False: its results were up to date and were read back


@dataclass
class StageSweepOutcome:
    """What a sweep of a stage study did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    results: dict[str, StageCaseResult]  # by case id
    runout_stages: list[str]
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


def runout_stage_names(study: Study) -> list[str]:
    """Names of the study's runout stages, in stage order."""
    return [stage.name for stage in study.stages if isinstance(stage, RunoutStage)]


def _read_case(study: Study, folder: Path, ran: bool) -> StageCaseResult:
    """The metrics of a finished case from its stage files."""
    paths = dict(zip((stage.name for stage in study.stages), result_paths(study, folder)))
    runout = {}
    for name in runout_stage_names(study):
        with xr.open_dataset(paths[name]) as ds:
            runout[name] = {key: float(ds[key]) for key in RUNOUT_SCALARS}
    with xr.open_dataset(paths[study.stages[-1].name]) as last:
        n_particles = int(last.sizes.get("particle", 0))
        collapse = ({key: float(last[key]) if key in last else np.nan for key in COLLAPSE_SCALARS}
                    if study.metrics is not None else {})
    return StageCaseResult(DONE, "", n_particles, runout, collapse, ran)


def run_stage_sweep(study: Study, out_dir: str | Path, *, force: bool = False,
                    progress: StageProgress | None = None, case_started=None,
                    max_memory_bytes: float | None = None) -> StageSweepOutcome:
    """Every case of ``study.sweep`` (module doc); results under ``out_dir``.  ``case_started(i, n,
    case)`` is called before each case.  StudyError (nothing written) for a sweep the memory
    cannot hold or a case the core refuses."""
    wall_start = time.perf_counter()
    cases = sweep_cases(study)
    largest = max(cases, key=lambda case: estimated_particles(case.study))
    check_memory(largest.study, processes=1, limit_bytes=max_memory_bytes)
    out_dir = Path(out_dir)
    study_path = out_dir / STUDY_FILE_NAME
    make_output_folder(out_dir / CASES_FOLDER)
    study_path.unlink(missing_ok=True)  # written again at the end; a stopped sweep must not show an old one
    results: dict[str, StageCaseResult] = {}
    for index, case in enumerate(cases):
        if case_started is not None:
            case_started(index, len(cases), case)
        folder = out_dir / CASES_FOLDER / case.case_id
        make_output_folder(folder)
        write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
        try:
            run = run_study(case.study, folder, progress=progress, force=force, max_memory_bytes=max_memory_bytes)
        except DivergenceError as error:
            results[case.case_id] = StageCaseResult(DIVERGED, str(error), 0, {}, {}, True)
            continue
        results[case.case_id] = _read_case(case.study, folder, ran=not run.up_to_date)
    dataset = stage_sweep_dataset(study, cases, results)
    write_dataset(dataset, study_path)
    figures = []
    if study.output.figures and runout_stage_names(study):
        from workflows.sweep.figures import draw_runout_sweep  # matplotlib only when drawing

        figures = draw_runout_sweep(out_dir, dataset)
    return StageSweepOutcome(out_dir, study_path, cases, results, runout_stage_names(study),
                             {"total": time.perf_counter() - wall_start}, figures)


def stage_sweep_dataset(study: Study, cases: list[SweepCase], results: dict[str, StageCaseResult]) -> xr.Dataset:
    """``study.nc`` of a stage study's sweep (module doc; variables ``STAGE_SWEEP_FILE``,
    ``RUNOUT_METRICS``, ``COLLAPSE_METRICS``)."""
    dims, shape, coords = sweep_coordinates(study, cases)
    stages = runout_stage_names(study)
    columns = {"case_folder": np.full(shape, "", dtype=object), "status": np.full(shape, "", dtype=object),
               "status_reason": np.full(shape, "", dtype=object), "n_particles": np.zeros(shape, dtype=np.int64)}
    runout = {key: np.full((*shape, len(stages)), np.nan) for key in RUNOUT_SCALARS}
    collapse = {key: np.full(shape, np.nan) for key in COLLAPSE_SCALARS}
    for case in cases:
        result, at = results[case.case_id], case.position
        columns["case_folder"][at] = case.case_id
        columns["status"][at] = result.status
        columns["status_reason"][at] = result.message
        columns["n_particles"][at] = result.n_particles
        for s, stage in enumerate(stages):
            for key, value in result.runout.get(stage, {}).items():
                runout[key][(*at, s)] = value
        for key, value in result.collapse.items():
            collapse[key][at] = value
    ds = xr.Dataset(coords=coords)
    for name, values in columns.items():
        ds[name] = STAGE_SWEEP_FILE[name].over(dims, values)
    if stages:
        ds = ds.assign_coords(runout_stage=("runout_stage", np.array(stages, dtype=object),
                                            {"units": "1", "long_name": "name of the runout stage"}))
        for key, values in runout.items():
            ds[key] = RUNOUT_METRICS[key].over((*dims, "runout_stage"), values)
    if study.metrics is not None:
        for key, values in collapse.items():
            ds[key] = COLLAPSE_METRICS[key].over(dims, values)
    sweep = study.sweep
    ds.attrs = {
        "title": f"spfem-fos parameter study {study.name}: the metrics of every case",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "sweep_combination": sweep.combination,
        "sweep_axes": ", ".join(axis.path for axis in sweep.axes),
        "n_cases": len(cases),
        **provenance(study),
    }
    return ds
