"""Running a study's stages on a simulation: the one sequence every stage goes through.

1. :func:`new_simulation`: the study's ``Simulation``; what the core refuses (a time step,
   particles the first mesh leaves out, a stage too long for the time step) is a StudyError;
2. :func:`stage_setup`: what the stage sets before it starts, from its kind (materials, body
   force, water), the study (supports, the load ramp of the first stage) and where it starts;
   ``Simulation.begin_stage`` applies it.  A strength-reduction run goes through the same
   (``workflows.fos.task``), starting from the gravity state;
3. :func:`run_stage_result`: the stage runs by its kind, and its result dataset is made from its
   records and final particles, with the kind's own variables and, after the last stage, the
   study's collapse metrics;
4. :func:`run_and_write_stage`: with the study's snapshots and animation, the file written and
   the kind's figures drawn; :func:`run_stages` does it for every stage of a study, in this process.

Every check that can fail on the input (the file, the particles, the time step) happens
before the output folder is created.  A study whose result files already hold exactly this
study text is not run again (``force=True`` runs it anyway).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import xarray as xr

from spfem_core.records import TimeSeries
from spfem_core.simulation import DetachedParticlesError, Simulation, StageSetup
from spfem_core.snapshot import Snapshot, StressState
from spfem_core.timestep import UnstableTimeStepError
from workflows.memory_guard import check_memory
from workflows.output.animation import AnimationRecorder
from workflows.output.metrics import add_metrics
from workflows.output.paraview import SnapshotWriter
from workflows.output.stage_file import is_up_to_date, result_paths, stage_dataset
from workflows.output.writing import interrupts_deferred, make_output_folder, write_dataset
from workflows.progress import Progress
from workflows.scene import monitor_particles, scene_and_flow, solver_settings, supports
from workflows.seepage.results import flow_line, seepage_dataset, write_seepage
from workflows.stages.base import CONTINUE, ORIGINAL_POSITIONS
from workflows.study import Study, StudyError
from workflows.water.pressure import study_water

MAX_STEPS_PER_STAGE = 1e9
"""A stage that would take more explicit steps than this is refused (days of wall time)."""
MIN_STEPS_PER_STAGE = 10
"""A stage shorter than this many steps is refused: nothing would move (a duration typed in the wrong
unit, or a density so large that one step outlasts the stage)."""

MAX_RECORDS_PER_STAGE = 1e7
"""A stage that would record more rows than this is refused (gigabytes of monitor history)."""


@dataclass
class StudyRun:
    """What :func:`run_stages` did."""

    paths: list[Path]
    up_to_date: bool = False  # True: nothing was run, the results were already there
    n_particles: int = 0
    n_steps: int = 0
    wall_time_s: float = 0.0
    dt_s: float = 0.0
    unconverged_stages: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # what a stage's result file flags (a runout not at rest)


class StageResult(NamedTuple):
    """One stage run: its records, its final particles and its result dataset (not written)."""

    series: TimeSeries
    final: Snapshot
    dataset: xr.Dataset


def new_simulation(study: Study, scene, threads: int = 0, initial_mesh=None) -> Simulation:
    """The study's Simulation (the compiled step on ``threads`` threads, 0: all cores; ``initial_mesh``
    the scene's first mesh when the caller has it); what the core refuses is a StudyError naming the
    field: a time step (``solver.cfl`` or ``solver.dt_s``), or particles the first mesh leaves out
    (``geometry.spacing_m``); and so is a stage too long for the time step (:func:`check_stage_lengths`)."""
    try:
        sim = Simulation(scene, solver_settings(study, threads), initial_mesh=initial_mesh)
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
        duration_s = stage.time_limit_s
        steps = duration_s / dt_s if dt_s > 0.0 else math.inf
        if steps < MIN_STEPS_PER_STAGE:
            raise StudyError(
                f"stages[{i}].{stage.duration_field}",
                f"{duration_s:g} s is {steps:.2g} steps of {dt_s:.3g} s (the stable step of these materials and "
                f"spacing), fewer than {MIN_STEPS_PER_STAGE}: the stage would not move; make it at least "
                f"{MIN_STEPS_PER_STAGE * dt_s:.2g} s",
            )
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


def stage_setup(study: Study, sim: Simulation, index: int, start_from: StressState | None = None) -> StageSetup:
    """What stage ``index`` sets before it starts (module doc, step 2): its kind's materials, body
    force and water, its active supports, the load ramp (the first stage only), and its start:
    ``start_from`` (a stored gravity state), else the original positions or where the last stage
    left off, as the stage says."""
    stage = study.stages[index]
    scene = sim.scene
    lines, node_line, pond = stage.water(study_water(study, scene.node_material), study, scene.node_material)
    start: str | StressState
    if start_from is not None:
        start = start_from
    else:
        start = ORIGINAL_POSITIONS if index > 0 and stage.start == ORIGINAL_POSITIONS else CONTINUE
    held = supports(study, scene, stage.boundary)
    return StageSetup(
        materials=stage.materials(sim.particle_materials), node_fixed=held.fixed,
        node_fixed_velocity_m_s=held.velocity_m_s, gravity_m_s2=stage.acceleration_m_s2(study),
        node_slip_length_m=held.slip_length_m, node_slip_side=held.slip_side,
        phreatic_lines_m=lines, node_phreatic_line=node_line, pond_level_m=pond,
        load_ramp_s=(study.loads.ramp_time_s or 0.0) if index == 0 else 0.0, start=start,
    )


def begin_stage(study: Study, sim: Simulation, index: int, start_from: StressState | None = None) -> None:
    """Set stage ``index`` up on ``sim`` (:func:`stage_setup`); a time step the core refuses for its
    materials is a StudyError naming the stage."""
    try:
        sim.begin_stage(stage_setup(study, sim, index, start_from))
    except UnstableTimeStepError as error:
        raise StudyError(f"stages[{index}]", str(error)) from None


def run_stage_result(study: Study, sim: Simulation, index: int, monitor_nodes: np.ndarray, *, progress=None,
                     snapshot=None) -> StageResult:
    """Set up stage ``index``, run it and make its result dataset (module doc, step 3).  Nothing is
    written."""
    stage = study.stages[index]
    begin_stage(study, sim, index)
    following = study.stages[index + 1] if index + 1 < len(study.stages) else None
    next_starts_over = following is not None and following.start == ORIGINAL_POSITIONS
    series = stage.run(sim, monitor_nodes, progress=progress, snapshot=snapshot, next_starts_over=next_starts_over)
    final = sim.snapshot(float(series.time_s[-1]))
    dataset = stage_dataset(study=study, stage_index=index, series=series, final=final,
                            monitor_particles=monitor_nodes)
    stage.add_results(dataset, study, series, final)
    if index == len(study.stages) - 1:
        add_metrics(dataset, study.metrics, final)
    return StageResult(series, final, dataset)


def snapshots(study: Study, index: int, out_dir: Path):
    """The ``snapshot`` argument of stage ``index``'s run and its animation recorder (or None):
    ParaView files every ``[output] snapshot_interval_s`` into ``out_dir/paraview``, animation frames
    every ``animation_interval_s`` of an animated stage; (None, None) when the study asks for neither."""
    output, stage = study.output, study.stages[index]
    callbacks: list[tuple[float, SnapshotWriter | AnimationRecorder]] = []
    if output.snapshot_interval_s is not None:
        callbacks.append((output.snapshot_interval_s, SnapshotWriter(Path(out_dir) / "paraview", stage.name)))
    recorder = None
    if output.animation_interval_s is not None and stage.animated:
        recorder = AnimationRecorder(Path(out_dir) / f"{stage.name}.gif", output.animation_colour)
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

    def __call__(self, snapshot: Snapshot) -> None:
        for i, (interval, callback) in enumerate(self.callbacks):
            if snapshot.time_s >= self.next_s[i] - 1e-9 * interval:
                callback(snapshot)
                self.next_s[i] = snapshot.time_s + interval


def run_and_write_stage(study: Study, sim: Simulation, index: int, path: Path, monitor_nodes: np.ndarray,
                        out_dir: Path, *, progress=None, attrs: dict | None = None) -> StageResult:
    """:func:`run_stage_result` with the study's snapshots, the dataset (``attrs`` added) written to
    ``path``, the animation and the kind's figures drawn (module doc, step 4)."""
    snapshot, recorder = snapshots(study, index, out_dir)
    result = run_stage_result(study, sim, index, monitor_nodes, progress=progress, snapshot=snapshot)
    result.dataset.attrs.update(attrs or {})
    partial = partial_path(path)  # the file takes its name once its animation and figures are drawn:
    write_dataset(result.dataset, partial)  # a process killed before that leaves no "up to date" result
    if recorder is not None:
        recorder.write()
    study.stages[index].figures(study, partial, out_dir)
    with interrupts_deferred():
        os.replace(partial, path)
    return result


def partial_path(path: Path) -> Path:
    """Where a stage's result file is written before its animation and figures are drawn."""
    return Path(path).with_name(Path(path).stem + ".partial.nc")


def run_stages(study: Study, out_dir: str | Path, *, progress: Progress | None = None, case: str = "",
               force=False, max_memory_bytes: float | None = None, flow=None) -> StudyRun:
    """Run every stage of ``study`` in this process and write its results under ``out_dir``
    (``progress.stage`` hears of each, with the ``case`` label); ``flow``: the flow its water comes from
    when the caller has it (``scene.water_flow``; else solved here).

    Raises StudyError (nothing written) for a study the core refuses or the memory cannot hold
    (``memory_guard``, limit ``max_memory_bytes``), and lets the core's DivergenceError through
    (the diverged stage writes no result).
    """
    progress = progress or Progress()
    out_dir = Path(out_dir)
    paths = result_paths(study, out_dir)
    if not force and all(is_up_to_date(path, study) for path in paths):
        return StudyRun(paths=paths, up_to_date=True)

    check_memory(study, processes=1, limit_bytes=max_memory_bytes)
    scene, flow = scene_and_flow(study, flow)
    monitor_nodes = monitor_particles(study, scene)
    sim = new_simulation(study, scene)

    make_output_folder(out_dir)
    for path in paths:  # results of another study text must not outlive a failed rerun
        path.unlink(missing_ok=True)
        partial_path(path).unlink(missing_ok=True)
    outcome = StudyRun(paths=paths, n_particles=int(sim.n_particles), dt_s=float(sim.dt_s))
    if flow is not None and study.transient is not None:  # the water at the study's time
        progress.message(flow.line())
    elif flow is not None:  # the flow every stage's pore pressure comes from
        write_seepage(study, seepage_dataset(study, flow), out_dir)
        progress.message(flow_line(flow))
    for index, (stage, path) in enumerate(zip(study.stages, paths)):
        report = lambda fraction, stage=stage: progress.stage(case, stage.name, stage.kind, fraction)  # noqa: E731
        result = run_and_write_stage(study, sim, index, path, monitor_nodes, out_dir, progress=report)
        series = result.series
        if result.dataset.attrs.get("warning"):
            outcome.warnings.append(f"warning: stage {stage.name!r}: {result.dataset.attrs['warning']}")
        outcome.n_steps += int(series.n_steps)
        outcome.wall_time_s += float(series.wall_time_s)
        if series.converged is False:
            outcome.unconverged_stages.append(stage.name)
    return outcome
