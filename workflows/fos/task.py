"""One strength-reduction run: the task a dask worker executes for one SRF value.

The task gets the study text, the gravity state (stress and plastic strain per particle)
and F; it rebuilds the scene (deterministic: same particles, same first mesh), divides the
strength (c / F, tan(phi) / F; psi_F by the stage's flow rule), runs the stage from the
original positions by the stage's protocol and returns the run's verdict
(``workflows.fos.verdict``) and its result file, made in memory on the worker
(``workflows.output.writing.dataset_bytes``).  It touches no file: the client only puts the
bytes on disk, so workers need not share a file system with it, and the client's process
(which shares the machine's cores with local workers) does little.

Protocols (``strength_reduction.protocol``):

- ``quasi_static``: the reduced strength at once, then dynamic relaxation with local damping
  (``damping``) at the largest stable step until the unbalanced-force ratio falls below
  ``tolerance`` (the slope is at rest) or ``duration_s`` (Dawson, Roth & Drescher 1999 in a
  large-deformation setting);
- ``ramp``: undamped dynamics with the strength falling linearly in 1/F from full to c / F over
  ``ramp_time_s`` (in ``RAMP_STEPS`` steps), then held; F <= 1 (a stronger slope) at once;
- ``sudden``: the reduced strength at once, undamped dynamics.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import netCDF4
import numpy as np
import xarray as xr
from distributed import Event
from xarray.backends import NetCDF4DataStore

from spfem_core.divergence import DivergenceError
from spfem_core.simulation import Simulation
from workflows.fos.scales import response_time_s
from workflows.fos.verdict import DIVERGED, verdict_for
from workflows.loading import body_acceleration_m_s2
from workflows.output.stage_file import stage_dataset
from workflows.output.writing import dataset_bytes
from workflows.scene import build_scene, monitor_particles, solver_settings, supports
from workflows.study import Study, parse_study


def _connected(rule, cancel_event: str, failing_event: str | None, failure_m: float):
    """``rule``, which also stops the run once the dask Event ``cancel_event`` is set (one round
    trip to the scheduler per check, about 50 per run) and sets the Event ``failing_event`` once
    the largest displacement passes ``failure_m``: the run will end failed, and the client can
    plan on it before the run ends (``workflows.fos.search``, step 5)."""
    cancel = Event(cancel_event)
    failing = Event(failing_event) if failing_event else None

    def checked(time_s, max_u_m, energy):
        nonlocal failing
        if failing is not None and max_u_m.size and float(np.max(max_u_m)) > failure_m:
            failing.set()
            failing = None  # once
        if cancel.is_set():
            return "cancelled by the client: the run can no longer change the answer"
        return rule(time_s, max_u_m, energy)

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
    file_bytes: bytes = b""  # the run's result file (stage_dataset, verdict, scalars and keys as attributes)

    @property
    def dataset(self) -> xr.Dataset:
        """The result file, read back (for inspection; the client writes ``file_bytes`` as they are)."""
        return xr.open_dataset(NetCDF4DataStore(netCDF4.Dataset("run.nc", mode="r", memory=self.file_bytes))).load()


RESULT_SCALARS = ("status", "status_reason", "max_displacement_m", "final_kinetic_energy_j_per_m", "stop_time_s",
                  "wall_time_s", "remesh_wall_s", "n_steps")
"""The fields of a result that its file carries as ``run_<name>`` attributes (read back on reuse)."""

RAMP_STEPS = 20
"""A strength ramp changes the materials this many times, evenly over ``ramp_time_s``."""


def reduced_materials(study: Study, scene, srf: float):
    """The scene's materials with the strength divided by ``srf`` under the stage's flow rule."""
    return scene.materials.with_strength_reduction(srf, associated=study.strength_reduction.flow_rule == "associated")


def _run_protocol(study: Study, scene, sim: Simulation, srf: float, monitors, stop):
    """The run of one SRF value by the stage's protocol (module doc); its TimeSeries."""
    stage = study.strength_reduction
    record = dict(record_interval_s=stage.record_interval_s, monitor_nodes=monitors, stop=stop)
    if stage.protocol == "quasi_static":
        sim.set_materials(reduced_materials(study, scene, srf))
        return sim.relax(damping=stage.damping_or_default, tolerance=stage.tolerance_or_default,
                         max_duration_s=stage.duration_s, **record)
    if stage.protocol == "sudden":
        sim.set_materials(reduced_materials(study, scene, srf))
        return sim.run(stage.duration_s, damping=0.0, **record)
    if srf <= 1.0:  # a stronger slope than built: nothing to ramp (and the slope as built may fail)
        sim.set_materials(reduced_materials(study, scene, srf))
        return sim.run(stage.duration_s, damping=0.0, **record)
    ramp_s = stage.ramp_time_s if stage.ramp_time_s is not None else default_ramp_time_s(study)
    step_s = ramp_s / RAMP_STEPS

    def ramp(time_s: float) -> None:
        """Set the strength of the ramp step that starts at ``time_s`` (held constant over it)."""
        fraction = min((time_s + step_s) / ramp_s, 1.0)
        if time_s < ramp_s:
            sim.set_materials(reduced_materials(study, scene, 1.0 / (1.0 - fraction * (1.0 - 1.0 / srf))))

    ramp(0.0)
    return sim.run(stage.duration_s, damping=0.0, periodic=(step_s, ramp), **record)


def default_ramp_time_s(study: Study) -> float:
    """``ramp_time_s`` when the study gives none: 4 response times of the slope
    (``scales.response_time_s``), at most half of ``duration_s``."""
    return min(4.0 * response_time_s(study), 0.5 * study.strength_reduction.duration_s)


def run_srf(study_text: str, gravity_stress_pa: np.ndarray, gravity_plastic_strain: np.ndarray, srf: float,
            cancel_event: str | None = None, run_key: str = "", gravity_key: str = "",
            failing_event: str | None = None):
    """Run strength-reduction factor ``srf`` from the gravity state; an :class:`SrfRunResult`.

    ``cancel_event``: name of a dask ``Event``; when it is set (the client found the run can no
    longer change the answer) the run stops at its next stop-rule check, so that its worker is
    free for a run that can.  ``failing_event``: name of a dask ``Event`` set once the run's largest
    displacement passes the failure displacement (it will end failed).  Both need
    ``stage.early_stop`` and ``cancel_event`` (the checks come with the stop rule).
    ``run_key`` and ``gravity_key`` (``workflows.fos.keys``, from the client) go into the file.
    """
    started_unix_s = time.time()
    study = parse_study(study_text)
    stage = study.strength_reduction
    stage_index = len(study.stages) - 1
    scene = build_scene(study)
    monitors = monitor_particles(study, scene)
    sim = Simulation(scene, solver_settings(study, threads=1))  # a dask worker: one core of its own
    sim.set_initial_stress(gravity_stress_pa, gravity_plastic_strain)
    sim.set_supports(*supports(study, scene, stage.boundary))
    sim.set_gravity(body_acceleration_m_s2(study, strength_reduction=True))
    verdict = verdict_for(study)
    remesh_start = sim.counters.remesh_wall_s
    stop = verdict.stop_rule() if stage.early_stop else None
    if stop is not None and cancel_event is not None:
        stop = _connected(stop, cancel_event, failing_event, verdict.failure_m)
    try:
        series = _run_protocol(study, scene, sim, float(srf), monitors, stop)
        status, reason = verdict.classify(series.time_s, series.max_displacement_m, series.converged)
    except DivergenceError as error:
        series = error.partial
        status, reason = DIVERGED, str(error)
        series.notes["diverged"] = str(error)
    ds = stage_dataset(study=study, stage_index=stage_index, series=series, sim=sim, monitor_particles=monitors)
    max_u = float(np.max(series.max_displacement_m)) if series.max_displacement_m.size else math.nan
    result = SrfRunResult(
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
        finished_unix_s=math.nan,
    )
    ds.attrs.update(srf=float(srf), status=status, status_reason=reason, run_key=run_key, gravity_key=gravity_key)
    ds.attrs.update({f"run_{name}": getattr(result, name) for name in RESULT_SCALARS})
    result.file_bytes = dataset_bytes(ds)
    result.finished_unix_s = time.time()
    return result
