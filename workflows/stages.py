"""Running a study: build its scene, run its stages in order, write one result per stage.

Every check that can fail on the input (the file, the particles, the time step) happens
before the output folder is created.  A study whose result files already hold exactly this
study text is not run again (``force=True`` runs it anyway).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from spfem_core.simulation import DetachedParticlesError, Simulation
from spfem_core.timestep import UnstableTimeStepError
from workflows.loading import stage_acceleration_m_s2, stage_water
from workflows.memory_guard import check_memory
from workflows.output.animation import AnimationRecorder
from workflows.output.metrics import add_metrics, add_runout_metrics
from workflows.output.paraview import SnapshotWriter
from workflows.output.stage_file import is_up_to_date, result_paths, stage_dataset
from workflows.output.writing import make_output_folder, write_dataset
from workflows.runout.figures import runout_fields
from workflows.runout.rest import rest_rule
from workflows.scene import build_scene, monitor_particles, solver_settings, supports
from workflows.study import DynamicStage, RelaxationStage, RunoutStage, StageBase, Study, StudyError

StageProgress = Callable[[StageBase, float], None]
"""Called with the running stage and the fraction of it done (0 to 1)."""


@dataclass
class StudyRun:
    """What a call of :func:`run_study` did."""

    paths: list[Path]
    up_to_date: bool = False  # True: nothing was run, the results were already there
    n_particles: int = 0
    n_steps: int = 0
    wall_time_s: float = 0.0
    dt_s: float = 0.0
    unconverged_stages: list[str] = field(default_factory=list)


def prepare_stage(sim: Simulation, study: Study, stage: StageBase, index: int) -> None:
    """Set the stage's materials (elastic or as declared), its active supports, the load ramp (first
    stage only), its body acceleration and water (the study's, or a runout stage's trigger) and its
    start."""
    materials = sim.scene.materials.as_elastic() if stage.elastic else sim.scene.materials
    if isinstance(stage, RunoutStage) and stage.strength_factor != 1.0:
        materials = materials.with_strength_reduction(stage.strength_factor)
    sim.set_materials(materials)
    sim.set_supports(*supports(study, sim.scene, stage.boundary))
    sim.set_load_ramp((study.loads.ramp_time_s or 0.0) if index == 0 else 0.0)
    sim.set_gravity(stage_acceleration_m_s2(study, stage))
    sim.set_water(*stage_water(study, stage, sim.scene.node_material))
    if index > 0 and stage.start == "original_positions":
        sim.discard_displacement()


def snapshots(study: Study, stage: StageBase, sim: Simulation, out_dir: Path):
    """The ``snapshot`` argument of a stage run and the animation recorder of the stage (or None):
    ParaView files every ``[output] snapshot_interval_s`` into ``out_dir/paraview``, animation frames
    every ``animation_interval_s`` of a dynamic or runout stage; (None, None) when the study asks for
    neither."""
    output = study.output
    callbacks = []
    if output.snapshot_interval_s is not None:
        callbacks.append((output.snapshot_interval_s, SnapshotWriter(Path(out_dir) / "paraview", stage.name, sim)))
    recorder = None
    if output.animation_interval_s is not None and isinstance(stage, (DynamicStage, RunoutStage)):
        recorder = AnimationRecorder(Path(out_dir) / f"{stage.name}.gif", sim, output.animation_colour)
        callbacks.append((output.animation_interval_s, recorder))
    if not callbacks:
        return None, None
    if len(callbacks) == 1:
        return callbacks[0], recorder
    return (min(interval for interval, _ in callbacks), _Every(callbacks)), recorder


class _Every:
    """Snapshot callbacks with their own intervals behind one (called at the smallest interval)."""

    def __init__(self, callbacks):
        self.callbacks = callbacks
        self.next_s = [0.0] * len(callbacks)

    def __call__(self, time_s: float) -> None:
        for i, (interval, callback) in enumerate(self.callbacks):
            if time_s >= self.next_s[i] - 1e-9 * interval:
                callback(time_s)
                self.next_s[i] = time_s + interval


def run_stage(sim: Simulation, stage: StageBase, monitor_nodes: np.ndarray, progress=None, snapshot=None,
              displacement_discarded: bool = False):
    """Run one stage on ``sim`` (which continues from its current state); the stage's TimeSeries.
    ``displacement_discarded``: the next stage starts from the original positions, so a relaxation
    balances the water pressures of those positions (``Simulation.relax``)."""
    match stage:
        case DynamicStage() | RunoutStage():
            at_rest = rest_rule(stage.rest_fraction, stage.rest_window_s) if isinstance(stage, RunoutStage) else None
            return sim.run(
                getattr(stage, stage.duration_field),
                damping=stage.damping,
                record_interval_s=stage.record_interval_s,
                monitor_nodes=monitor_nodes,
                progress=progress,
                snapshot=snapshot,
                stop=at_rest,
            )
        case RelaxationStage():
            return sim.relax(
                damping=stage.damping,
                tolerance=stage.tolerance,
                max_duration_s=stage.max_duration_s,
                record_interval_s=stage.record_interval_s,
                monitor_nodes=monitor_nodes,
                progress=progress,
                snapshot=snapshot,
                water_at_initial_positions=displacement_discarded,
            )
    raise TypeError(f"no runner for a stage of kind {stage.kind!r}")


MAX_STEPS_PER_STAGE = 1e9
"""A stage that would take more explicit steps than this is refused (days of wall time)."""

MAX_RECORDS_PER_STAGE = 1e7
"""A stage that would record more rows than this is refused (gigabytes of monitor history)."""


def new_simulation(study: Study, scene, threads: int = 0) -> Simulation:
    """The study's Simulation (the compiled step on ``threads`` threads, 0: all cores); what the core refuses is a StudyError naming the field: a time step
    (``solver.cfl`` or ``solver.dt_s``), or particles the first mesh leaves out (``geometry.spacing_m``);
    and so is a stage too long for the time step (:func:`check_stage_lengths`)."""
    try:
        sim = Simulation(scene, solver_settings(study, threads))
    except UnstableTimeStepError as error:
        raise StudyError("solver.dt_s" if study.solver.dt_s is not None else "solver.cfl", str(error)) from None
    except DetachedParticlesError as error:
        raise StudyError("geometry.spacing_m", f"{study.geometry.spacing_m:g} m: {error}") from None
    check_stage_lengths(study, sim.dt_s)
    return sim


def check_stage_lengths(study: Study, dt_s: float) -> None:
    """StudyError when a stage would take more than ``MAX_STEPS_PER_STAGE`` steps of ``dt_s`` or
    record more than ``MAX_RECORDS_PER_STAGE`` rows (an SRF run counts as a stage)."""
    for i, stage in enumerate(study.stages):
        duration_s = getattr(stage, stage.duration_field)
        steps = duration_s / dt_s if dt_s > 0.0 else math.inf
        if not steps <= MAX_STEPS_PER_STAGE:
            raise StudyError(
                f"stages[{i}].{stage.duration_field}",
                f"{duration_s:g} s is about {steps:.2g} steps of {dt_s:.3g} s (the stable step of these materials "
                f"and spacing), more than {MAX_STEPS_PER_STAGE:g}",
            )
        records = duration_s / max(stage.record_interval_s, dt_s)  # dt_s > 0 here
        if not records <= MAX_RECORDS_PER_STAGE:
            raise StudyError(
                f"stages[{i}].record_interval_s",
                f"{stage.record_interval_s:g} s gives about {records:.2g} records in {duration_s:g} s, more than "
                f"{MAX_RECORDS_PER_STAGE:g}",
            )


def run_stage_result(study: Study, sim: Simulation, index: int, monitor_nodes: np.ndarray, *, progress=None,
                     snapshot=None):
    """Prepare stage ``index``, run it and make its result dataset (collapse metrics after the
    last stage); (the stage's TimeSeries, the dataset).  Nothing is written."""
    stage = study.stages[index]
    try:
        prepare_stage(sim, study, stage, index)
    except UnstableTimeStepError as error:
        raise StudyError(f"stages[{index}]", str(error)) from None
    following = study.stages[index + 1] if index + 1 < len(study.stages) else None
    discarded = following is not None and following.start == "original_positions"
    series = run_stage(sim, stage, monitor_nodes, progress, snapshot, displacement_discarded=discarded)
    dataset = stage_dataset(study=study, stage_index=index, series=series, sim=sim, monitor_particles=monitor_nodes)
    if isinstance(stage, RunoutStage):
        dataset = add_runout_metrics(dataset, study, stage, series, sim)
    if index == len(study.stages) - 1:
        dataset = add_metrics(dataset, study.metrics, sim)
    return series, dataset


def run_and_write_stage(
    study: Study, sim: Simulation, index: int, path: Path, monitor_nodes: np.ndarray, out_dir: Path,
    *, progress=None, attrs: dict | None = None,
):
    """:func:`run_stage_result` with the study's snapshots, the dataset (``attrs`` added) written to
    ``path``; the stage's TimeSeries."""
    snapshot, recorder = snapshots(study, study.stages[index], sim, out_dir)
    series, dataset = run_stage_result(study, sim, index, monitor_nodes, progress=progress, snapshot=snapshot)
    dataset.attrs.update(attrs or {})
    write_dataset(dataset, path)
    if recorder is not None:
        recorder.write()
    stage = study.stages[index]
    if isinstance(stage, RunoutStage) and study.output.figures:
        runout_fields(path, Path(out_dir) / f"{stage.name}.png", stage.strength_factor)
    return series


def run_study(study: Study, out_dir: str | Path, *, progress: StageProgress | None = None, force=False,
              max_memory_bytes: float | None = None) -> StudyRun:
    """Run every stage of ``study`` and write its results under ``out_dir``.

    Raises StudyError (nothing written) for a study the core refuses or the memory cannot hold
    (``memory_guard``, limit ``max_memory_bytes``), and lets the core's DivergenceError through
    (the diverged stage writes no result).
    """
    out_dir = Path(out_dir)
    paths = result_paths(study, out_dir)
    if not force and all(is_up_to_date(path, study) for path in paths):
        return StudyRun(paths=paths, up_to_date=True)

    check_memory(study, processes=1, limit_bytes=max_memory_bytes)
    scene = build_scene(study)
    monitor_nodes = monitor_particles(study, scene)
    sim = new_simulation(study, scene)

    make_output_folder(out_dir)
    for path in paths:  # results of another study text must not outlive a failed rerun
        path.unlink(missing_ok=True)
    outcome = StudyRun(paths=paths, n_particles=int(sim.n_particles), dt_s=float(sim.dt_s))
    for index, (stage, path) in enumerate(zip(study.stages, paths)):
        report = None if progress is None else (lambda fraction, stage=stage: progress(stage, fraction))
        series = run_and_write_stage(study, sim, index, path, monitor_nodes, out_dir, progress=report)
        outcome.n_steps += int(series.n_steps)
        outcome.wall_time_s += float(series.wall_time_s)
        if series.converged is False:
            outcome.unconverged_stages.append(stage.name)
    return outcome
