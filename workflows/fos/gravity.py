"""The gravity state of a strength-reduction study: run once, stored, reused while its key holds.

The stages before the ``strength_reduction`` stage run in the study's own process and are
stored as ``OUT/<stage>.nc`` (``gravity.nc``) with ``gravity_key`` (``workflows.fos.keys``).
A later invocation with the same key reads the stresses back instead of relaxing again.
"""

from __future__ import annotations

import time
from pathlib import Path

import xarray as xr

from workflows.fos.keys import gravity_key
from workflows.output.stage_file import particle_stress
from workflows.output.writing import interrupts_deferred, make_output_folder
from workflows.scene import build_scene, monitor_particles
from workflows.stages import new_simulation, run_and_write_stage
from workflows.study import Study


def gravity_paths(study: Study, out_dir: Path) -> list[Path]:
    return [out_dir / f"{stage.name}.nc" for stage in study.stages[:-1]]


def read_gravity(path: Path, key: str):
    """(stress (n, 4), plastic strain (n,)) from a gravity file with this key, else None."""
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            if ds.attrs.get("gravity_key") != key:
                return None
            return particle_stress(ds), ds["particle_plastic_strain"].values.copy()
    except (OSError, KeyError, ValueError, RuntimeError):
        return None


def gravity_state(study: Study, out_dir: Path, *, force: bool, progress):
    """Run (or reuse) the stages before the strength reduction; (stress, plastic strain, reused, n, wall s)."""
    key = gravity_key(study)
    paths = gravity_paths(study, out_dir)
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene)
    if not force and all(path.is_file() for path in paths):
        state = read_gravity(paths[-1], key)
        if state is not None and state[0].shape == (scene.n_particles, 4):
            progress.message(f"gravity state reused from {paths[-1]} (its inputs are unchanged)")
            return state[0], state[1], True, scene.n_particles, 0.0
    make_output_folder(out_dir)
    start = time.perf_counter()
    for index, (stage, path) in enumerate(zip(study.stages[:-1], paths)):
        report = lambda fraction, name=stage.name: progress.stage(name, fraction)  # noqa: E731
        series = run_and_write_stage(study, sim, index, path, monitors, out_dir, progress=report,
                                     attrs={"gravity_key": key})
        if series.converged is False:
            progress.message(f"warning: stage {stage.name!r} reached max_duration_s before converging")
    return sim.nodes.stress_pa.copy(), sim.nodes.plastic_strain.copy(), False, scene.n_particles, time.perf_counter() - start


