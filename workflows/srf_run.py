"""One strength-reduction run: the task a dask worker executes for one SRF value.

The task gets the study text, the gravity state (stress and plastic strain per particle)
and F; it rebuilds the scene (deterministic: same particles, same first mesh), divides the
strength (c / F, tan(phi) / F), runs the stage undamped from the original positions and
returns the run's dataset with its verdict.  It touches no file: the client writes the
results, so workers need not share a file system with it.

Verdicts (:mod:`workflows.fos_criterion`):

- ``failed``: the largest displacement passed ``failure_displacement_m``, or the run was
  still moving at the end (the running maximum of the displacement grew by more than
  ``rest_growth`` of itself over the last ``rest_window_s`` and not less than over the
  window before);
- ``stable``: otherwise (and a run that came to rest early);
- ``diverged``: the solver detected a blow-up; the run is left out of the curve.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from workflows.fos_criterion import DIVERGED, FAILED, STABLE
from workflows.study import StrengthReductionStage, Study, parse_study


def failure_displacement_m(study: Study) -> float:
    """The stage's ``failure_displacement_m``, default 10% of the height of the domain."""
    stage = study.strength_reduction
    if stage.failure_displacement_m is not None:
        return stage.failure_displacement_m
    ys = [y for _, y in study.geometry.polygon_m]
    return 0.1 * (max(ys) - min(ys))


def displacement_floor_m(study: Study) -> float:
    """The stage's ``displacement_floor_m``, default failure_displacement_m / 1000."""
    stage = study.strength_reduction
    if stage.displacement_floor_m is not None:
        return stage.displacement_floor_m
    return failure_displacement_m(study) / 1000.0


def _window_growth(time_s: np.ndarray, max_u_m: np.ndarray, window_s: float) -> tuple[float, float, float]:
    """(u now, growth over the last window, growth over the window before) of the running
    maximum of the largest displacement."""
    running = np.maximum.accumulate(max_u_m)
    t = time_s[-1]
    u_now = float(running[-1])
    u_1 = float(np.interp(t - window_s, time_s, running))
    u_2 = float(np.interp(t - 2.0 * window_s, time_s, running))
    return u_now, u_now - u_1, u_1 - u_2


@dataclass(frozen=True)
class Verdict:
    """How one run ended."""

    failure_m: float
    floor_m: float
    window_s: float
    growth: float

    def past_failure(self, max_u_m: np.ndarray) -> bool:
        return bool(max_u_m.size) and float(np.max(max_u_m)) > self.failure_m

    def at_rest(self, time_s, max_u_m) -> bool:
        """Displacement no longer growing: less than ``growth`` of itself per window, and slowing."""
        if time_s[-1] < 2.0 * self.window_s:
            return False
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last <= self.growth * max(u_now, self.floor_m) and last <= before

    def still_moving(self, time_s, max_u_m) -> bool:
        """Displacement still growing at the end (more than ``growth`` per window, not slowing)."""
        if time_s[-1] < 2.0 * self.window_s:
            return True
        u_now, last, before = _window_growth(time_s, max_u_m, self.window_s)
        return last > self.growth * max(u_now, self.floor_m) and last >= before

    def stop_rule(self):
        """The early-stop rule handed to ``Simulation.run``."""

        def rule(time_s, max_u_m, kinetic):
            if self.past_failure(max_u_m):
                return f"failed: largest displacement {float(np.max(max_u_m)):.3g} m > {self.failure_m:g} m"
            if self.at_rest(time_s, max_u_m):
                return f"at rest: largest displacement grew < {self.growth:g} of itself in the last {self.window_s:g} s"
            return None

        return rule

    def classify(self, time_s, max_u_m) -> tuple[str, str]:
        """(status, one-line reason) of a finished run."""
        peak = float(np.max(max_u_m))
        if self.past_failure(max_u_m):
            return FAILED, f"largest displacement {peak:.3g} m > failure_displacement_m {self.failure_m:g} m"
        if self.still_moving(time_s, max_u_m):
            _, last, _ = _window_growth(time_s, max_u_m, self.window_s)
            return FAILED, f"still moving at the end: +{last:.3g} m in the last {self.window_s:g} s (not slowing)"
        return STABLE, f"largest displacement {peak:.3g} m, not growing at the end"


def verdict_for(study: Study) -> Verdict:
    stage: StrengthReductionStage = study.strength_reduction
    return Verdict(failure_displacement_m(study), displacement_floor_m(study), stage.rest_window_s, stage.rest_growth)


def _cancellable(rule, event_name: str):
    """``rule``, which also stops the run once the dask Event ``event_name`` is set (one round
    trip to the scheduler per check, about 50 per run)."""
    from distributed import Event

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
    dataset: object  # xarray.Dataset of the run (workflows.results.run_dataset)


def run_srf(study_text: str, gravity_stress_pa: np.ndarray, gravity_plastic_strain: np.ndarray, srf: float,
            cancel_event: str | None = None):
    """Run strength-reduction factor ``srf`` from the gravity state; an :class:`SrfRunResult`.

    ``cancel_event``: name of a dask ``Event``; when it is set (the client found the run can no
    longer change the answer) the run stops at its next stop-rule check, so that its worker is
    free for a run that can.  Needs ``stage.early_stop`` (the checks come with the stop rule).
    """
    # imported here: the worker process compiles (or loads from the disk cache) on first use
    started_unix_s = time.time()
    from spfem_core.simulation import DivergenceError, Simulation
    from workflows.results import run_dataset
    from workflows.scene_builder import build_scene, monitor_particles, solver_settings, supports

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
    remesh_start = sim.remesh_wall_s
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
    ds = run_dataset(study=study, stage_index=stage_index, series=series, sim=sim, scene=scene, monitor_particles=monitors)
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
        remesh_wall_s=float(sim.remesh_wall_s - remesh_start),
        n_steps=int(series.n_steps),
        started_unix_s=started_unix_s,
        finished_unix_s=time.time(),
        dataset=ds,
    )
