"""A stage's loop between compiled calls: a dynamic stage (:func:`run`) and a relaxation (:func:`relax`).

Each compiled call (``stepper.advance``) runs many steps and returns why it stopped.  Between
calls Python decides, in this order: whether the run diverged (``divergence``: a speed, the energy
budget, a mesh that collapsed), whether the mesh is rebuilt (an inverted element, a failed quality
check, a detached particle that can rejoin: ``Simulation.rebuild_mesh``), whether the record
buffers grow or the relaxation has converged, then, each on its own schedule of stage time
(``schedule``), the stop rule (:data:`StopRule`), the snapshots (:data:`SnapshotHook`), a periodic
action (:data:`PeriodicAction`) and the progress.  The stage ends with its ``records.TimeSeries``
and the notes of what ran.

The functions work on a ``simulation.Simulation``: its state, mesh and time step; they are its
``run`` and ``relax``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from spfem_core.divergence import DivergenceError, EnergyWatch, MeshCollapse, speed_reason
from spfem_core.jit import kernel_threads, set_threads
from spfem_core.records import RecordBuffers, TimeSeries, record_state
from spfem_core.remeshing import ANGLE_MARGIN_RAD
from spfem_core.schedule import StageSchedule
from spfem_core.snapshot import Snapshot
from spfem_core.state import StepParameters
from spfem_core.stepper import (
    LOOP_CONTACTS,
    LOOP_LAST_MAX_SPEED,
    LOOP_LAST_RATIO,
    LOOP_MESH_CHECKS,
    LOOP_NEXT_RECORD,
    STATUS_BUFFER_FULL,
    STATUS_CONVERGED,
    STATUS_DONE,
    STATUS_INVERTED,
    STATUS_MESH_CHECK,
    STATUS_NOT_FINITE,
    STATUS_RUNAWAY,
    advance,
)

StopRule = Callable[[np.ndarray, np.ndarray, np.ndarray], "str | None"]
"""Asked between compiled calls with the records so far (time_s, max_displacement_m,
energy_j_per_m with the columns of ``energy_budget.ENERGY_COLUMNS``; read-only views): a reason (one
line) to end the stage now, or None."""

SnapshotHook = tuple[float, Callable[[Snapshot], None]]
"""(interval in s, callback(the particles at that moment, a ``snapshot.Snapshot``))."""

PeriodicAction = tuple[float, Callable[[float], None]]
"""(interval in s, callback(stage time in s)) called every interval of stage time, not at the
start or the end: it may change the simulation (a step of a strength ramp: ``set_materials``)."""


def run(sim, duration_s: float, damping: float, record_interval_s: float | None, monitor_nodes,
        progress: Callable[[float], None] | None, stop: StopRule | None, snapshot: SnapshotHook | None,
        periodic: PeriodicAction | None) -> TimeSeries:
    """``Simulation.run``: ``duration_s`` of explicit steps at the dynamic time step, with local
    damping ``damping`` and the water pressures at the current positions."""
    sim.loads = sim.loads._replace(at_initial_positions=False)
    return _loop(sim, duration_s, damping, 0.0, record_interval_s, monitor_nodes, progress, stop, snapshot, periodic)


def relax(sim, damping: float, tolerance: float, max_duration_s: float, record_interval_s: float | None,
          monitor_nodes, progress: Callable[[float], None] | None, snapshot: SnapshotHook | None,
          stop: StopRule | None, water_at_initial_positions: bool, elastic_solve_first: bool) -> TimeSeries:
    """``Simulation.relax``: damped steps until the unbalanced-force ratio is below ``tolerance``
    (``stepper``), or ``max_duration_s`` of pseudo-time, or the stop rule.

    Only the end state of a relaxation counts, not its path, so it steps at the largest accepted
    cfl, 1 / (1 + beta), whatever the solver's cfl or dt_s (the dynamic stages keep those), with
    the relaxation's inertia (``Simulation.set_inertia``): on the reference slope 2,758 steps
    instead of 4,938 at cfl 0.5, the relaxed stresses equal within 3.4e-6 of their largest value
    (tolerance 1e-5).  With ``elastic_solve_first`` it starts from the direct solve
    (``elastic_solve.solve_elastic``; the series' note ``elastic_solve`` says whether it applied).
    Afterwards the simulation steps at its masses and dynamic time step again."""
    if not tolerance > 0.0:
        raise ValueError(f"tolerance must be > 0, got {tolerance}")
    sim.relaxing = True
    sim.loads = sim.loads._replace(at_initial_positions=bool(water_at_initial_positions))
    solve_note = sim.solve_elastic(tolerance) if elastic_solve_first else "off"
    sim.set_inertia()
    sim.dt_s = sim.time_step.relaxation(sim.critical_dt_s, sim.beta)
    try:
        series = _loop(sim, max_duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, stop,
                       snapshot)
        series.notes["elastic_solve"] = solve_note
        return series
    finally:
        sim.relaxing = False
        sim.set_inertia()
        sim.choose_time_step()


def _step_parameters(sim, damping: float, tolerance: float) -> StepParameters:
    """The scalars of the simulation's steps now (``state.StepParameters``)."""
    return StepParameters(
        sim.gravity_m_s2, sim.dt_s, float(damping), sim.beta,
        sim.scene.spacing_m, sim.speed_limit_m_s, float(tolerance), sim.remesher.threshold_rad,
        ANGLE_MARGIN_RAD, kernel_threads(sim.threads), _inertia_is_mass(sim),
    )


def _inertia_is_mass(sim) -> bool:
    """Whether the next compiled call's leapfrog can read the masses as the inertia (``integration``
    module doc): no relaxation has scaled it.  Asked before every call, as a relaxation's inertia
    follows the mesh; its cost, one pass over a column, is that of the speed check here."""
    return bool(np.array_equal(sim.nodes.inertia_kg, sim.nodes.mass_kg))


class _StageStart(NamedTuple):
    """Counters at the start of a stage, to report the stage's own share."""

    rebuilds: int
    smoothed: int
    remesh_wall_s: float
    mesh_checks: float


def _loop(sim, duration_s, damping, tolerance, record_interval_s, monitor_nodes, progress, stop=None,
          snapshot=None, periodic=None) -> TimeSeries:
    """Compiled calls until the stage's time is up, or it converged (``tolerance`` > 0), or the stop
    rule ends it (module doc); a DivergenceError with the records so far when it diverges."""
    if not duration_s > 0.0:
        raise ValueError(f"duration_s must be > 0, got {duration_s}")
    if not 0.0 <= damping < 1.0:
        raise ValueError(f"damping must be in [0, 1), got {damping}")
    start_wall = time.perf_counter()
    sim.threads = set_threads(sim.settings.threads, sim.n_particles)  # numba's choice is per calling thread
    monitor_nodes = np.ascontiguousarray(monitor_nodes, dtype=np.int64).reshape(-1)
    interval = float(record_interval_s) if record_interval_s else max(duration_s / 1000.0, sim.dt_s)
    records = RecordBuffers.empty(int(min(duration_s / interval, 1e6)) + 2, monitor_nodes.size)
    sim.loop[LOOP_NEXT_RECORD] = interval
    sim.dissipated[:] = 0.0  # dissipation is recorded since the stage start
    _record(sim, records, 0.0, monitor_nodes)

    sim.stage_first_dt_s = sim.dt_s
    start = _StageStart(sim.counters.rebuilds, sim.counters.smoothed, sim.counters.remesh_wall_s,
                        float(sim.loop[LOOP_MESH_CHECKS]))
    # prescribed motion does work the budget does not count
    energy_watch = None if sim.prescribes_motion else EnergyWatch(records)
    stage_time = 0.0
    n_steps = 0
    converged = None if tolerance == 0.0 else False
    stop_reason = ""
    schedule = StageSchedule(duration_s, sim.n_particles, stop is not None,
                             None if snapshot is None else float(snapshot[0]),
                             None if periodic is None else float(periodic[0]))
    if snapshot is not None:
        snapshot[1](sim.snapshot(0.0))

    def partial_series():
        return _series(sim, records, n_steps, start, start_wall, converged)

    while schedule.running(stage_time, sim.dt_s):
        schedule.plan_landing_check(sim.n_orphans > 0, n_steps, float(np.abs(sim.nodes.velocity_m_s).max()),
                                    sim.scene.spacing_m, sim.dt_s)
        n_want = schedule.next_call_steps(stage_time, sim.dt_s, n_steps)
        call_start = time.perf_counter()
        status, done = advance(
            sim.nodes, sim.scratch, sim.mesh_arrays, sim.material_arrays,
            sim.walls, sim.loads, _step_parameters(sim, damping, tolerance), n_want, stage_time, interval,
            monitor_nodes, records, sim.dissipated, sim.loop,
        )
        schedule.adapt(done, time.perf_counter() - call_start)
        stage_time += done * sim.dt_s
        n_steps += done
        sim.counters.steps += done

        reason = None
        if status in (STATUS_NOT_FINITE, STATUS_RUNAWAY):
            reason = speed_reason(status == STATUS_NOT_FINITE, sim.loop[LOOP_LAST_MAX_SPEED], sim.speed_limit_m_s)
        elif energy_watch is not None:
            reason = energy_watch.reason(records)
        if reason is not None:
            raise DivergenceError(reason, sim.counters.steps, stage_time, partial_series())
        try:
            if status in (STATUS_INVERTED, STATUS_MESH_CHECK):
                sim.rebuild_mesh()
            elif schedule.landing_check_due(n_steps):
                if sim.n_orphans and sim.remesher.orphans_can_rejoin(sim.nodes.xy_m, sim.mesh):
                    sim.rebuild_mesh()
        except MeshCollapse as collapse:
            raise DivergenceError(str(collapse), sim.counters.steps, stage_time, partial_series()) from None
        if status == STATUS_BUFFER_FULL:
            records = records.grown()
        elif status == STATUS_CONVERGED:
            converged = True
            break
        elif status not in (STATUS_DONE, STATUS_MESH_CHECK, STATUS_INVERTED):
            raise RuntimeError(f"unknown status {status} from the time loop")
        if schedule.stop_check_due(stage_time, sim.dt_s):
            n_rec = records.n_filled
            early = stop(records.time_s[:n_rec], records.max_displacement_m[:n_rec], records.energy_j_per_m[:n_rec])
            if early:
                stop_reason = str(early)
                break
        if schedule.snapshot_due(stage_time, sim.dt_s):
            snapshot[1](sim.snapshot(stage_time))
        if schedule.action_due(stage_time, sim.dt_s):
            periodic[1](stage_time)
        if progress is not None:
            progress(min(stage_time / duration_s, 1.0))
    if schedule.final_snapshot_due(stage_time, sim.dt_s):
        snapshot[1](sim.snapshot(stage_time))  # the end, unless it was a snapshot time already
    if records.time_s[records.n_filled - 1] < stage_time - 1e-12 * max(stage_time, 1.0):
        if records.n_filled >= records.capacity:
            records = records.grown()
        _record(sim, records, stage_time, monitor_nodes)
    if progress is not None:
        progress(1.0)
    series = _series(sim, records, n_steps, start, start_wall, converged)
    if stop_reason:
        series.notes["early_stop"] = f"stopped at t = {series.time_s[-1]:.4g} s of {duration_s:g} s: {stop_reason}"
    return series


def _record(sim, records: RecordBuffers, time_s: float, monitor_nodes: np.ndarray) -> None:
    """A row of ``records`` of the state now, at stage time ``time_s``."""
    slot = records.n_filled
    record_state(slot, time_s, sim.nodes, sim.scratch.area_m2, sim.material_arrays, sim.gravity_m_s2,
                 monitor_nodes, sim.dissipated, records)
    records.count[0] = slot + 1


def _series(sim, records: RecordBuffers, n_steps: int, start: _StageStart, start_wall: float,
            converged) -> TimeSeries:
    """The stage's time series so far, with the notes of what ran."""
    beta = sim.beta
    n_remesh = sim.counters.rebuilds - start.rebuilds
    n_checks = int(sim.loop[LOOP_MESH_CHECKS] - start.mesh_checks)
    n_walls = sim.walls.xy_m.shape[0]
    plastic = sim.materials.plastic
    notes = {
        "stabilisation": (
            f"on (beta = {beta:g})" if beta > 0
            else "off in a relaxation of elastic materials (the bonds vanish at rest): bond loop skipped"
            if sim.relaxing and sim.settings.stabilisation_beta > 0 else "off (beta = 0): bond loop skipped"
        ),
        "contact": (
            f"on ({n_walls} walls, {int(sim.loop[LOOP_CONTACTS])} particles touching at the end)"
            if n_walls
            else "off (no walls): contact loop skipped"
        ),
        "remesh": (
            f"{n_remesh} rebuilds and {n_checks} exact quality checks in {n_steps} steps; "
            f"{sim.counters.smoothed - start.smoothed} crowded particles smoothed; "
            f"{sim.counters.remesh_wall_s - start.remesh_wall_s:.2f} s rebuilding"
        ),
        "plasticity": "on" if plastic else "off (all materials elastic)",
        "water_and_loads": "on" if sim.loads.active else "off (no water, no surface loads): skipped",
        "particles_outside_mesh": f"{sim.n_orphans} at the end",
    }
    series = TimeSeries.from_records(
        records, dt_s=sim.dt_s, n_steps=n_steps, n_remesh=n_remesh, n_mesh_checks=n_checks,
        wall_time_s=time.perf_counter() - start_wall, converged=converged,
        unbalanced_force_ratio=float(sim.loop[LOOP_LAST_RATIO]), notes=notes,
    )
    if converged is True:
        notes["early_stop"] = f"relaxation converged after {n_steps} steps (t = {series.time_s[-1]:.4g} s)"
    return series
