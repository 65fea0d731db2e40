"""Shortcuts for the quasi-static SRF runs that were measured and not taken (docs/benchmarks.md).

    python -m benchmarks.relaxation_shortcuts tolerance              # h = 0.3 m, SRF 1.2 1.3 1.3667 1.375 1.4
    python -m benchmarks.relaxation_shortcuts step --spacing 0.5 --srf 1.2 --factors 0.909 1.1 1.3 1.5
    python -m benchmarks.relaxation_shortcuts warm_start --spacing 0.5 --srf 1.2 1.3 1.3333 1.3667
    python -m benchmarks.relaxation_shortcuts kinetic --srf 1.2 1.3 1.3667 1.375 1.4

Each SRF run of the reference slope (``studies/reference_slope.toml``) starts from the same
gravity state, on one thread, and prints its steps, end time, largest displacement and whether it
converged (or diverged):

- ``tolerance``: the stage's convergence tolerance at the default 1e-5 and at 1e-4, the loosest
  accepted;
- ``step``: the relaxation's time step at ``--factors`` times the critical-step bound instead of
  ``timestep.max_stable_cfl(beta)`` (0.909 at beta = 0.1), by replacing the run's
  ``TimeStepPolicy.relaxation``: a measurement of the stability margin, not an option of the code;
- ``warm_start``: each SRF after the first from the gravity state (as the study runs it) and from
  the stress and plastic strain the run at the SRF before it ended with (a StressState, the
  particles back at their initial positions): steps, and the largest displacement, the warm
  run's added to the one it started from;
- ``kinetic``: kinetic damping (Cundall's, the dynamic relaxation of Day and Otter): every velocity
  set to zero whenever the kinetic energy sum m_i |v|^2 / 2 passes a peak, with local damping 0
  and 0.3 beside it, against the study's local damping 0.7 alone; each run as a worker runs it
  (``workflows.fos.task.run_srf``: its stop rule, verdict and steps).  The peak test runs between
  steps in Python, one compiled step per call: the steps are the measure, not the wall time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from spfem_core.divergence import DivergenceError
from spfem_core.stepper import STATUS_DONE
from workflows.scene import build_scene, monitor_particles
from workflows.stages.running import begin_stage, new_simulation
from workflows.study import parse_study

STUDY = Path(__file__).resolve().parents[1] / "studies" / "reference_slope.toml"


def study_at(spacing_m: float, tolerance: float | None = None):
    """The reference slope at ``spacing_m``, its SRF stage at ``tolerance`` (None: the default)."""
    text = STUDY.read_text().replace("spacing_m = 0.3", f"spacing_m = {spacing_m}")
    if tolerance is not None:
        text = text.replace('kind = "strength_reduction"', f'kind = "strength_reduction"\ntolerance = {tolerance}')
    return parse_study(text)


def gravity_state(study, scene):
    sim = new_simulation(study, scene, threads=1)
    begin_stage(study, sim, 0)
    study.stages[0].run(sim, [], next_starts_over=True)
    return sim.snapshot().stress_state


def srf_run(study, scene, state, srf: float, step_factor: float | None = None) -> str:
    """One run from ``state``; a line of what it did."""
    return run_and_state(study, scene, state, srf, step_factor)[0]


def run_and_state(study, scene, state, srf: float, step_factor: float | None = None, u_before_m: float = 0.0):
    """(a line of what one run from ``state`` did, its final StressState or None when it diverged,
    its largest displacement plus ``u_before_m``)."""
    sim = new_simulation(study, scene, threads=1)
    begin_stage(study, sim, len(study.stages) - 1, start_from=state)
    if step_factor is not None:
        sim.time_step.relaxation = lambda critical_dt_s, beta: step_factor * critical_dt_s
    try:
        run = study.strength_reduction.run_at(sim, srf, study, monitor_particles(study, scene), None)
    except DivergenceError as error:
        return f"diverged: {error}", None, np.nan
    u_m = float(np.max(run.max_displacement_m)) + u_before_m
    return (f"steps {run.n_steps:6d}  t {run.time_s[-1]:.3f} s  largest u {u_m:.5f} m  converged {run.converged}",
            sim.snapshot().stress_state, u_m)


def kinetic_advance(real_advance, resets: list, damping: float):
    """``stepper.advance`` one step at a time with local damping ``damping``, all velocities zeroed
    when the kinetic energy (inertia-weighted) falls below its value a step before (a peak passed);
    the step of every reset is appended to ``resets``."""
    previous = [0.0]

    def advance(nodes, scratch, mesh, materials, walls, loads, params, n_steps, time_start_s, *rest):
        params = params._replace(damping=damping)
        done = 0
        while done < n_steps:
            status, k = real_advance(nodes, scratch, mesh, materials, walls, loads, params, 1,
                                     time_start_s + done * params.dt_s, *rest)
            done += k
            if status != STATUS_DONE:
                return status, done
            v = nodes.velocity_m_s
            kinetic = 0.5 * float(np.sum(nodes.inertia_kg * (v[:, 0] ** 2 + v[:, 1] ** 2)))
            if kinetic < previous[0]:
                v[~nodes.fixed] = 0.0
                previous[0] = 0.0
                resets.append(done)
            else:
                previous[0] = kinetic
        return STATUS_DONE, done

    return advance


def kinetic_runs(spacing_m: float, srf_values) -> None:
    """The ``kinetic`` shortcut (module doc)."""
    import spfem_core.stage_loop as stage_loop
    from workflows.fos.task import run_srf

    real_advance = stage_loop.advance
    base = study_at(spacing_m)
    state = gravity_state(base, build_scene(base))
    for label, local, kinetic in (("local 0.7 (shipped)", 0.7, False), ("kinetic, local 0", 0.0, True),
                                  ("kinetic, local 0.3", 0.3, True)):
        study = base
        for srf in srf_values:
            resets: list = []
            stage_loop.advance = kinetic_advance(real_advance, resets, local) if kinetic else real_advance
            try:
                record = run_srf(study, state, srf).record
            finally:
                stage_loop.advance = real_advance
            print(f"{label:>20}  SRF {srf:g}: steps {record.n_steps:6d}  t {record.stop_time_s:.3f} s  largest u "
                  f"{record.max_displacement_m:.5f} m  {record.status}" + (f"  ({len(resets)} resets)" if kinetic else ""),
                  flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("shortcut", choices=("tolerance", "step", "warm_start", "kinetic"))
    parser.add_argument("--spacing", type=float, default=0.3, help="particle spacing (m), default 0.3")
    parser.add_argument("--srf", type=float, nargs="+", default=[1.2, 1.3, 1.3667, 1.375, 1.4])
    parser.add_argument("--factors", type=float, nargs="+", default=[0.909, 1.1, 1.3, 1.5],
                        help="step: relaxation steps as fractions of the critical-step bound")
    args = parser.parse_args()
    if args.shortcut == "kinetic":
        kinetic_runs(args.spacing, args.srf)
        return
    study = study_at(args.spacing)
    scene = build_scene(study)
    state = gravity_state(study, scene)
    if args.shortcut == "tolerance":
        for tolerance in (1e-5, 1e-4):
            variant = study_at(args.spacing, tolerance)
            for srf in args.srf:
                print(f"tolerance {tolerance:g}  SRF {srf:g}: {srf_run(variant, scene, state, srf)}", flush=True)
    elif args.shortcut == "warm_start":
        values = sorted(args.srf)
        _, before, u_before_m = run_and_state(study, scene, state, values[0])
        for srf in values[1:]:
            cold, cold_state, u_cold_m = run_and_state(study, scene, state, srf)
            warm = run_and_state(study, scene, before, srf, u_before_m=u_before_m)[0]
            print(f"SRF {srf:g} from gravity:   {cold}", flush=True)
            print(f"SRF {srf:g} from the last:  {warm}", flush=True)
            before, u_before_m = cold_state, u_cold_m
    else:
        for factor in args.factors:
            for srf in args.srf:
                print(f"step {factor:g} x bound  SRF {srf:g}: {srf_run(study, scene, state, srf, factor)}", flush=True)


if __name__ == "__main__":
    main()
