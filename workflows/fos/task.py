"""One strength-reduction run: the task a dask worker executes for one SRF value.

The task gets the study text, the gravity state (stress and plastic strain per particle)
and F; it rebuilds the scene (deterministic: same particles, same first mesh), divides the
strength (c / F, tan(phi) / F), runs the stage undamped from the original positions and
returns the run's dataset with its verdict (``workflows.fos.verdict``).  It touches no file:
the client writes the results, so workers need not share a file system with it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from distributed import Event

from spfem_core.divergence import DivergenceError
from spfem_core.simulation import Simulation
from workflows.fos.verdict import DIVERGED, verdict_for
from workflows.output.stage_file import stage_dataset
from workflows.scene import build_scene, monitor_particles, solver_settings, supports
from workflows.study import parse_study


def _cancellable(rule, event_name: str):
    """``rule``, which also stops the run once the dask Event ``event_name`` is set (one round
    trip to the scheduler per check, about 50 per run)."""
    event = Event(event_name)

    def checked(time_s, max_u_m, kinetic):
        if event.is_set():
            return "cancelled by the client: the run can no longer change the answer"
        return rule(time_s, max_u_m, kinetic)

    return checked


@dataclass
class SrfRunResult:
    """What a worker sends back for one SRF value."""

    srf: float
    status: str
    status_reason: str
    max_displacement_m: float  # largest displacement of any particle during the run
    final_kinetic_energy_j_per_m: float
    stop_time_s: float  # simulated time reached (< duration_s when stopped early)
    wall_time_s: float
    remesh_wall_s: float
    n_steps: int
    started_unix_s: float  # wall clock on the worker when the task started and ended (time.time())
    finished_unix_s: float
    dataset: object  # xarray.Dataset of the run (workflows.output.stage_file.stage_dataset)


def run_srf(study_text: str, gravity_stress_pa: np.ndarray, gravity_plastic_strain: np.ndarray, srf: float,
            cancel_event: str | None = None):
    """Run strength-reduction factor ``srf`` from the gravity state; an :class:`SrfRunResult`.

    ``cancel_event``: name of a dask ``Event``; when it is set (the client found the run can no
    longer change the answer) the run stops at its next stop-rule check, so that its worker is
    free for a run that can.  Needs ``stage.early_stop`` (the checks come with the stop rule).
    """
    started_unix_s = time.time()
    study = parse_study(study_text)
    stage = study.strength_reduction
    stage_index = len(study.stages) - 1
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = Simulation(scene, solver_settings(study))
    sim.set_initial_stress(gravity_stress_pa, gravity_plastic_strain)
    sim.set_materials(scene.materials.with_strength_reduction(float(srf)))
    sim.set_supports(*supports(study, scene, stage.boundary))
    verdict = verdict_for(study)
    remesh_start = sim.counters.remesh_wall_s
    stop = verdict.stop_rule() if stage.early_stop else None
    if stop is not None and cancel_event is not None:
        stop = _cancellable(stop, cancel_event)
    try:
        series = sim.run(
            stage.duration_s, damping=0.0, record_interval_s=stage.record_interval_s, monitor_nodes=monitors,
            stop=stop,
        )
        status, reason = verdict.classify(series.time_s, series.max_displacement_m)
    except DivergenceError as error:
        series = error.partial
        status, reason = DIVERGED, str(error)
        series.notes["diverged"] = str(error)
    ds = stage_dataset(study=study, stage_index=stage_index, series=series, sim=sim, monitor_particles=monitors)
    max_u = float(np.max(series.max_displacement_m)) if series.max_displacement_m.size else math.nan
    ds.attrs.update(srf=float(srf), status=status, status_reason=reason)
    return SrfRunResult(
        srf=float(srf),
        status=status,
        status_reason=reason,
        max_displacement_m=max_u,
        final_kinetic_energy_j_per_m=float(series.kinetic_energy_j_per_m[-1]),
        stop_time_s=float(series.time_s[-1]),
        wall_time_s=float(series.wall_time_s),
        remesh_wall_s=float(sim.counters.remesh_wall_s - remesh_start),
        n_steps=int(series.n_steps),
        started_unix_s=started_unix_s,
        finished_unix_s=time.time(),
        dataset=ds,
    )
