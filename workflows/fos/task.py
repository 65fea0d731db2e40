"""One strength-reduction run: the task a dask worker executes for one SRF value, and its record.

The task gets the study text, the gravity state (``spfem_core.snapshot.StressState``) and F; it
rebuilds the scene (deterministic: same particles, same first mesh), sets the stage up as every
stage is set up (``workflows.stages.running.stage_setup``, starting from the gravity state), runs
it by the stage's protocol at F (``StrengthReductionStage.run_at``) and returns the run's verdict
(``workflows.fos.verdict``) with its result file, made in memory on the worker
(``workflows.output.writing.dataset_bytes``).  It touches no file: the client only puts the
bytes on disk, so workers need not share a file system with it, and the client's process
(which shares the machine's cores with local workers) does little.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import time
from dataclasses import dataclass

import netCDF4
import numpy as np
import xarray as xr
from distributed import Event
from xarray.backends import NetCDF4DataStore

from spfem_core.divergence import DivergenceError
from spfem_core.mesh import Mesh, triangulate
from spfem_core.snapshot import StressState
from workflows.fos.search import RunOutcome
from workflows.fos.verdict import DIVERGED, FAILED, verdict_for
from workflows.output.stage_file import stage_dataset
from workflows.output.writing import dataset_bytes
from workflows.scene import build_scene, monitor_particles
from workflows.stages.running import begin_stage, new_simulation
from workflows.study import Study, parse_study


@dataclass(frozen=True)
class RunRecord:
    """One SRF run as the search, ``summary.nc``, the report and a sweep see it."""

    srf: float
    status: str  # verdict.STABLE, FAILED or DIVERGED
    status_reason: str
    max_displacement_m: float  # largest displacement of any particle during the run
    final_kinetic_energy_j_per_m: float
    stop_time_s: float  # simulated time reached (< duration_s when stopped early)
    wall_time_s: float
    remesh_wall_s: float
    n_steps: int
    started_s: float = math.nan  # on its worker, since the study started (NaN: made by an earlier invocation)
    finished_s: float = math.nan
    n_particles: int = 0

    @property
    def outcome(self) -> RunOutcome:
        """What the search needs of it."""
        return RunOutcome(self.srf, self.max_displacement_m, self.status)


RUN_FIELDS = ("all", "failed", "none")
"""Which runs' files carry the final particle state (:class:`RunPolicy`)."""


@dataclass(frozen=True)
class RunPolicy:
    """What a case's runs keep and when they end: every run keeps its particle fields and runs until
    its stop rule ends it, unless a probabilistic study asks for less of its realisations
    (``[probabilistic] keep_fields``; ``workflows.probabilistic.study_type``)."""

    fields: str = "all"  # RUN_FIELDS: every run, only failed runs, or none keep the particle state
    stop_at_failure: bool = False  # end once the largest displacement passes the failure displacement:
    # the verdict (failed) is then known, and nothing else of the run is used (a realisation's one run)

    def keeps_fields(self, status: str) -> bool:
        """Whether a run that ended ``status`` keeps its particle fields."""
        return self.fields == "all" or (self.fields == "failed" and status == FAILED)

    def covered_by(self, fields: str) -> bool:
        """Whether a run file made under ``fields`` (RUN_FIELDS) keeps every particle state this policy
        keeps: all covers failed covers none."""
        return RUN_FIELDS.index(fields) <= RUN_FIELDS.index(self.fields)


PARTICLE_FIELDS_ATTRIBUTE = "particle_fields"
"""A run file's attribute: 1 when it holds the final particle state, 0 when its policy left it out."""
FIELDS_POLICY_ATTRIBUTE = "run_fields"
"""A run file's attribute: the ``RunPolicy.fields`` it was made under (a later study that keeps more
makes it again)."""

RESULT_SCALARS = ("status", "status_reason", "max_displacement_m", "final_kinetic_energy_j_per_m", "stop_time_s",
                  "wall_time_s", "remesh_wall_s", "n_steps")
"""The fields of a record that its file carries as ``run_<name>`` attributes (read back on reuse)."""


@dataclass
class SrfRunResult:
    """What a worker sends back for one SRF value: its record, when it ran, its result file."""

    record: RunRecord
    started_unix_s: float  # wall clock on the worker when the task started and ended (time.time())
    finished_unix_s: float
    file_bytes: bytes = b""  # the run's result file (stage_dataset, verdict, scalars and keys as attributes)

    @property
    def srf(self) -> float:
        return self.record.srf

    @property
    def dataset(self) -> xr.Dataset:
        """The result file, read back (for inspection; the client writes ``file_bytes`` as they are)."""
        return xr.open_dataset(NetCDF4DataStore(netCDF4.Dataset("run.nc", mode="r", memory=self.file_bytes))).load()

    def record_since(self, study_start_unix_s: float) -> RunRecord:
        """The record with its start and end on the worker in s since the study started."""
        return dataclasses.replace(self.record, started_s=self.started_unix_s - study_start_unix_s,
                                   finished_s=self.finished_unix_s - study_start_unix_s)


def held(value):
    """``value`` (the gravity state the runs start from, the steady flow they share) as the result of a
    task rather than scattered data: when every worker holding it dies, the scheduler runs this task
    again on another (scattered data would be lost, and every run waiting for it cancelled)."""
    return value


FIRST_MESHES_KEPT = 4
"""First meshes a worker keeps (:func:`first_mesh`): the clouds of the studies it serves at once."""
_first_meshes: dict[bytes, Mesh] = {}


def first_mesh(scene) -> Mesh:
    """The alpha-shape mesh of the scene's particles at their initial positions, triangulated once
    per cloud on this worker: every run of a study (every realisation of a probabilistic one) starts
    from the same cloud, whose Delaunay triangulation is a tenth of a small run.  Keyed on the
    positions, spacings and alpha themselves, so a different cloud never gets another's mesh."""
    digest = hashlib.blake2b(digest_size=16)
    spacing = scene.spacing_m if scene.node_spacing_m is None else scene.node_spacing_m
    for part in (scene.node_xy_m, np.asarray(spacing, dtype=np.float64), np.float64(scene.alpha)):
        digest.update(np.ascontiguousarray(part).tobytes())
    key = digest.digest()
    mesh = _first_meshes.pop(key, None)
    if mesh is None:
        mesh = triangulate(scene.node_xy_m, spacing, scene.alpha)
    _first_meshes[key] = mesh  # most recent last
    while len(_first_meshes) > FIRST_MESHES_KEPT:
        del _first_meshes[next(iter(_first_meshes))]
    return mesh


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


def run_srf(study: Study | str, gravity: StressState, srf: float, cancel_event: str | None = None, run_key: str = "",
            gravity_key: str = "", failing_event: str | None = None, policy: RunPolicy = RunPolicy(),
            flow=None) -> SrfRunResult:
    """Run strength-reduction factor ``srf`` of ``study`` (a checked Study, as the engine sends it: no
    parsing on the worker; or its text) from the gravity state; an :class:`SrfRunResult`.

    ``cancel_event``: name of a dask ``Event``; when it is set (the client found the run can no
    longer change the answer) the run stops at its next stop-rule check, so that its worker is
    free for a run that can.  ``failing_event``: name of a dask ``Event`` set once the run's largest
    displacement passes the failure displacement (it will end failed).  Both need
    ``stage.early_stop`` and ``cancel_event`` (the checks come with the stop rule).
    ``run_key`` and ``gravity_key`` (``workflows.fos.keys``, from the client) go into the file.
    ``policy``: which runs keep their particle fields, and whether the run ends at the failure
    displacement (:class:`RunPolicy`); ``flow``: the study's steady flow, solved by the client
    (``workflows.seepage.flow``), which the scene then takes instead of solving it again.
    """
    started_unix_s = time.time()
    study = parse_study(study) if isinstance(study, str) else study
    stage = study.strength_reduction
    stage_index = len(study.stages) - 1
    scene = build_scene(study, flow)
    monitors = monitor_particles(study, scene)
    sim = new_simulation(study, scene, threads=1, initial_mesh=first_mesh(scene))  # a worker: one core of its own
    begin_stage(study, sim, stage_index, start_from=gravity)
    verdict = verdict_for(study)
    remesh_start = sim.counters.remesh_wall_s
    stop = verdict.stop_rule(at_failure=policy.stop_at_failure) if stage.early_stop else None
    if stop is not None and cancel_event is not None:
        stop = _connected(stop, cancel_event, failing_event, verdict.failure_m)
    try:
        series = stage.run_at(sim, float(srf), study, monitors, stop)
        status, reason = verdict.classify(series.time_s, series.max_displacement_m, series.converged)
    except DivergenceError as error:
        series = error.partial
        status, reason = DIVERGED, str(error)
        series.notes["diverged"] = str(error)
    ds = stage_dataset(study=study, stage_index=stage_index, series=series, final=sim.snapshot(series.time_s[-1]),
                       monitor_particles=monitors, particles=policy.keeps_fields(status))
    max_u = float(np.max(series.max_displacement_m)) if series.max_displacement_m.size else math.nan
    record = RunRecord(
        srf=float(srf), status=status, status_reason=reason, max_displacement_m=max_u,
        final_kinetic_energy_j_per_m=float(series.kinetic_energy_j_per_m[-1]), stop_time_s=float(series.time_s[-1]),
        wall_time_s=float(series.wall_time_s), remesh_wall_s=float(sim.counters.remesh_wall_s - remesh_start),
        n_steps=int(series.n_steps), n_particles=scene.n_particles,
    )
    ds.attrs.update(srf=float(srf), status=status, status_reason=reason, run_key=run_key, gravity_key=gravity_key)
    ds.attrs[PARTICLE_FIELDS_ATTRIBUTE] = int(policy.keeps_fields(status))
    ds.attrs[FIELDS_POLICY_ATTRIBUTE] = policy.fields
    ds.attrs.update({f"run_{name}": getattr(record, name) for name in RESULT_SCALARS})
    file_bytes = dataset_bytes(ds)
    return SrfRunResult(record, started_unix_s, time.time(), file_bytes)
