"""The gravity state of a strength-reduction study: run once, stored, reused while its key holds.

The stages before the ``strength_reduction`` stage make the gravity state, stored as
``OUT/<stage>.nc`` (``gravity.nc``) with ``gravity_key`` (``workflows.fos.keys``).  A later
invocation with the same key reads the stresses back instead of relaxing again.  A single
study runs them in its own process, while its cluster starts (:func:`gravity_state`); a sweep
runs each case's as a dask task (:func:`run_gravity`), and the client writes its files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.fos.keys import gravity_key
from workflows.output.stage_file import particle_stress, provenance
from workflows.output.writing import interrupts_deferred, make_output_folder, write_dataset
from workflows.scene import build_scene, monitor_particles
from workflows.stages import new_simulation, run_and_write_stage, run_stage_result
from workflows.study import Study, parse_study


def gravity_paths(study: Study, out_dir: Path) -> list[Path]:
    return [out_dir / f"{stage.name}.nc" for stage in study.stages[:-1]]


def read_gravity(path: Path, key: str):
    """(stress (n, 4), plastic strain (n,)) from a gravity file with this key, else None
    (:func:`why_not_reused` says why)."""
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            if ds.attrs.get("gravity_key") != key:
                return None
            return particle_stress(ds), ds["particle_plastic_strain"].values.copy()
    except (OSError, KeyError, ValueError, RuntimeError):
        return None


def stored_gravity(study: Study, out_dir: Path):
    """The gravity state on disk for this study's key, (stress, plastic strain), or None."""
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


def gravity_state(study: Study, out_dir: Path, *, force: bool, progress):
    """Run (or reuse) the stages before the strength reduction in this process;
    (stress, plastic strain, reused, n particles, wall s)."""
    key = gravity_key(study)
    paths = gravity_paths(study, out_dir)
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene)
    state = None if force else stored_gravity(study, out_dir)
    if state is not None and state[0].shape == (scene.n_particles, 4):
        progress.message(f"gravity state reused from {paths[-1]} (its inputs are unchanged)")
        return state[0], state[1], True, scene.n_particles, 0.0
    if not force and paths[-1].is_file():
        reason = why_not_reused(study, out_dir) if state is None else f"{paths[-1].name} has another particle count"
        progress.message(f"gravity state relaxed again: {reason}")
    make_output_folder(out_dir)
    start = time.perf_counter()
    for index, (stage, path) in enumerate(zip(study.stages[:-1], paths)):
        report = lambda fraction, name=stage.name: progress.stage(name, fraction)  # noqa: E731
        series = run_and_write_stage(study, sim, index, path, monitors, out_dir, progress=report,
                                     attrs={"gravity_key": key})
        if series.converged is False:
            progress.message(f"warning: stage {stage.name!r} reached max_duration_s before converging")
    return sim.nodes.stress_pa.copy(), sim.nodes.plastic_strain.copy(), False, scene.n_particles, time.perf_counter() - start


@dataclass
class GravityResult:
    """What a worker sends back for one case's gravity state."""

    stress_pa: np.ndarray  # (n, 4)
    plastic_strain: np.ndarray  # (n,)
    datasets: list  # xarray.Dataset per stage before the strength reduction, with gravity_key
    n_particles: int
    wall_time_s: float
    unconverged: list[str] = field(default_factory=list)  # stages that reached max_duration_s


def run_gravity(study_text: str) -> GravityResult:
    """The dask task of a case's gravity state: the stages before the strength reduction, run on
    a worker; no file is written (no snapshots either)."""
    start = time.perf_counter()
    study = parse_study(study_text)
    key = gravity_key(study)
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene, threads=1)  # a dask worker: one core of its own
    datasets, unconverged = [], []
    for index, stage in enumerate(study.stages[:-1]):
        series, dataset = run_stage_result(study, sim, index, monitors)
        dataset.attrs["gravity_key"] = key
        datasets.append(dataset)
        if series.converged is False:
            unconverged.append(stage.name)
    return GravityResult(sim.nodes.stress_pa.copy(), sim.nodes.plastic_strain.copy(), datasets, scene.n_particles,
                         time.perf_counter() - start, unconverged)


def write_gravity(study: Study, out_dir: Path, result: GravityResult) -> None:
    """Write the datasets of a gravity task to the case's folder, with the case's own study text
    (cases with one gravity key share one task)."""
    make_output_folder(out_dir)
    for dataset, path in zip(result.datasets, gravity_paths(study, out_dir)):
        write_dataset(dataset.assign_attrs(provenance(study)), path)


def copy_gravity(donor_study: Study, donor_dir: Path, study: Study, out_dir: Path) -> None:
    """Write the gravity files of ``donor_dir`` (a study with the same gravity key) to ``out_dir``,
    with ``study``'s own text."""
    make_output_folder(out_dir)
    for source, target in zip(gravity_paths(donor_study, donor_dir), gravity_paths(study, out_dir)):
        with interrupts_deferred(), xr.open_dataset(source, engine="netcdf4") as ds:
            dataset = ds.load()
        write_dataset(dataset.assign_attrs(provenance(study)), target)
