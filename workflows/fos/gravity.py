"""The gravity state of a strength-reduction study: one path, run once, stored, reused while its key holds.

The stages before the ``strength_reduction`` stage make the gravity state (the stress and plastic
strain every SRF run starts from, a ``spfem_core.snapshot.StressState``), stored as
``OUT/<stage>.nc`` (``gravity.nc``) with ``gravity_key`` (``workflows.fos.keys``).  A later
invocation with the same key reads it back instead of relaxing again.

:func:`run_gravity` runs them, wherever the engine places it: in the study's process while the
cluster starts (a single study: on all cores, with the study's snapshots and animations), or as
a dask task on a worker (a sweep's cases: one core, no snapshots).  Either way the client writes
the files (:func:`write_gravity`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import xarray as xr

from spfem_core.snapshot import StressState
from workflows.fos.keys import gravity_key
from workflows.output.stage_file import provenance, stress_state
from workflows.output.writing import interrupts_deferred, make_output_folder, share_file, write_dataset
from workflows.progress import Progress
from workflows.scene import monitor_particles, scene_and_flow
from workflows.seepage.results import FIGURE_NAME, FILE_NAME, seepage_dataset, write_seepage
from workflows.stages.running import new_simulation, run_stage_result, snapshots
from workflows.study import Study, parse_study


@dataclass
class GravityResult:
    """What the gravity stages made: the state, a dataset per stage (with ``gravity_key``)."""

    state: StressState
    datasets: list  # xarray.Dataset per stage before the strength reduction
    n_particles: int
    wall_time_s: float
    unconverged: list[str] = field(default_factory=list)  # stages that reached max_duration_s
    flow: Any = None  # the study's steady flow (``workflows.seepage.flow.StudyFlow``), or None


def gravity_paths(study: Study, out_dir: Path) -> list[Path]:
    return [out_dir / f"{stage.name}.nc" for stage in study.stages[:-1]]


def read_gravity(path: Path, key: str) -> StressState | None:
    """The gravity state in a gravity file with this key, else None (:func:`why_not_reused` says why)."""
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            if ds.attrs.get("gravity_key") != key:
                return None
            return stress_state(ds)
    except (OSError, KeyError, ValueError, RuntimeError):
        return None


def stored_gravity(study: Study, out_dir: Path) -> StressState | None:
    """The gravity state on disk for this study's key, or None."""
    paths = gravity_paths(study, out_dir)
    if not all(path.is_file() for path in paths):
        return None
    return read_gravity(paths[-1], gravity_key(study))


def why_not_reused(study: Study, out_dir: Path) -> str:
    """Why :func:`stored_gravity` found nothing to reuse: a missing file, another key, or the error
    reading it (for the message of a study that relaxes gravity again)."""
    paths = gravity_paths(study, out_dir)
    missing = [path.name for path in paths if not path.is_file()]
    if missing:
        return f"no {', '.join(missing)}"
    try:
        with xr.open_dataset(paths[-1], engine="netcdf4") as ds:
            stored = ds.attrs.get("gravity_key")
            ds["particle_plastic_strain"].values  # noqa: B018  (reads it, as read_gravity does)
    except (OSError, KeyError, ValueError, RuntimeError) as error:
        return f"{paths[-1].name} could not be read ({type(error).__name__}: {error})"
    if stored != gravity_key(study):
        return f"{paths[-1].name} has gravity_key {stored}, this study {gravity_key(study)}"
    return f"{paths[-1].name} reads now (it did not a moment ago)"


def run_gravity(study_text: str, threads: int = 1, out_dir: Path | None = None,
                progress: Progress | None = None, case: str = "", flow=None) -> GravityResult:
    """Run the stages before the strength reduction of the study ``study_text`` on ``threads`` threads
    (1: a dask worker's one core; 0: all cores).  With ``out_dir`` (made once the study's checks
    have passed), the study's snapshots and animations go there and ``progress.stage`` hears of each
    stage (of case ``case``).  No result file is written (:func:`write_gravity`).  ``flow``: the study's flow
    when the caller has it (``workflows.scene.water_flow``; else solved here)."""
    start = time.perf_counter()
    study = parse_study(study_text)
    key = gravity_key(study)
    scene, flow = scene_and_flow(study, flow)  # the client writes the flow, the runs reuse it
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene, threads=threads)
    if out_dir is not None:
        make_output_folder(out_dir)  # once the study's checks have passed: a refused study writes nothing
    datasets, unconverged = [], []
    for index, stage in enumerate(study.stages[:-1]):
        snapshot, recorder = snapshots(study, index, out_dir) if out_dir is not None else (None, None)
        report = None if progress is None else (
            lambda fraction, name=stage.name: progress.stage(case, name, "gravity", fraction))
        result = run_stage_result(study, sim, index, monitors, progress=report, snapshot=snapshot)
        if recorder is not None:
            recorder.write()
        result.dataset.attrs["gravity_key"] = key
        datasets.append(result.dataset)
        if result.series.converged is False:
            unconverged.append(stage.name)
    return GravityResult(sim.snapshot().stress_state, datasets, scene.n_particles, time.perf_counter() - start,
                         unconverged, flow)


def write_gravity(study: Study, out_dir: Path, result: GravityResult) -> None:
    """Write the datasets of a gravity run to the case's folder, with the case's own study text
    (the other cases with its key share these files: :func:`share_gravity`)."""
    make_output_folder(out_dir)
    for dataset, path in zip(result.datasets, gravity_paths(study, out_dir)):
        write_dataset(dataset.assign_attrs(provenance(study)), path)
    if result.flow is not None and study.transient is None:  # a transient study writes its own (transient.nc)
        write_seepage(study, seepage_dataset(study, result.flow), out_dir)


def share_gravity(study: Study, source_dir: Path, out_dir: Path) -> None:
    """Put the gravity files of ``source_dir`` (a case with the same gravity key) in ``out_dir`` as
    hard links to them (``output.writing.share_file``): a sweep's cases that share a gravity state
    share one file on disk, each folder still holding its own ``gravity.nc``.  The files name the
    study of the case that computed them; the key they carry is this case's too."""
    make_output_folder(out_dir)
    names = [path.name for path in gravity_paths(study, source_dir)]
    if study.seepage is not None:  # the flow the shared gravity state was relaxed with
        names += [FILE_NAME, FIGURE_NAME] if study.output.figures else [FILE_NAME]
    for name in names:
        if (source_dir / name).is_file():
            share_file(source_dir / name, out_dir / name)
