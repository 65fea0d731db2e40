"""``spfem-fos check STUDY.toml``: a study looked at before it runs.

The study is read and checked as a run reads it, and every check the run makes before its first
step is made in the same order (a refusal is the same one line, exit code 2): the study type's
(``StudyType.check``: the resolution, the memory of as many processes as the run holds, a
probabilistic study's draws and its realisations 0 and 1), every case a type makes only as it is
about to run (``StudyType.check_every_case``: every realisation of a probabilistic study), the
scene (particles, materials, supports, water, loads, random fields), the simulation (the time step,
the first mesh, the stages' lengths) and the steady flow of ``[seepage]``.  Then, without a step
run:

- ``OUT/section.png``: the section as the run will see it: particles coloured by material, the
  particles a support holds (x, y or both), walls, water (piezometric lines dashed, ponded water
  solid), surface loads (arrows), monitors and refined zones;
- the particle count and the memory of one simulation (``memory_guard.BYTES_PER_PARTICLE``);
- for a strength-reduction study, an estimate of the time of one SRF run and of the study.

**Run-time estimate.**  A quasi-static SRF run is a damped relaxation: its pseudo-time is a few
response times T = 4 H_domain / V_s of the slope (``StrengthReductionStage.response_time_s``, with
the moduli the runs use, ``stiffness_factor``), whatever the spacing, and its step is about the
time a P wave takes to cross the finest spacing, dt ~ h_min / V_p (equalised inertia,
``spfem_core.timestep``).  So

    steps = K T / dt,   run time = RUN_OVERHEAD_S + steps (STEP_OVERHEAD_S + N SECONDS_PER_PARTICLE_STEP),

with K = ``STABLE_RESPONSE_TIMES`` for a run that comes to rest and ``FAILED_RESPONSE_TIMES`` for
one that slides (at most ``duration_s``).  A search over the stage's range makes about
``FULL_SEARCH_RUNS`` (stable, failed) runs, one in a predicted window ``WINDOW_RUNS`` (a probabilistic
study's realisations: ``VARIABLE_WINDOW_RUNS``, random fields ``FIELD_WINDOW_RUNS``; a full search where the prediction does not see what the cases differ in:
:func:`windows_miss`), a verdict-mode realisation one; a refinement study's levels run at
their own particles and time steps (:func:`study_runs_s`).  Many cases' searches share the workers
(:func:`many_searches_s`), and so do a sweep's gravity states with their water
(:func:`worker_gravities`); a lone search keeps ``LONE_SEARCH_WORKERS`` of them busy and waits
``LONE_RUN_WAIT_S`` a run for its decisions (:func:`lone_search_s`).  The study's own process adds
``STARTUP_S`` (Python, the cluster, one gravity state, the figures) and what the workers wait for
(:func:`client_s`): its water's solve and its limit-equilibrium estimates as check measures them
here (:class:`ClientWork`), the report's scene with its water again, a refinement level's gravity
state, and for the FOS against time each time's gravity state and figures.  Every constant is
measured with the command its docstring names (docs/benchmarks.md, "Run-time estimate", with the
command that compares the estimate with the measured time of every shipped study).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

from workflows.fos.critical_circle import CriticalCircle, critical_circle, domain_warnings
from workflows.memory_guard import BYTES_PER_PARTICLE
from workflows.output.writing import make_output_folder
from workflows.scene import monitor_particles, random_field_notes, scene_and_flow, water_flow
from workflows.section_figure import draw_section
from workflows.seepage.results import flow_line
from workflows.stages.running import new_simulation
from workflows.study import Study
from workflows.study.reading import sweep_cases
from workflows.transient.flow import WaterAt, transient_flow

STABLE_RESPONSE_TIMES = 3.0
"""Pseudo-time of a run that comes to rest, in response times (module doc)."""

FAILED_RESPONSE_TIMES = 12.0
"""Pseudo-time of a run that slides, in response times."""

SECONDS_PER_PARTICLE_STEP = 76e-9
"""One thread's time per particle and step of a plastic relaxation step."""

STEP_OVERHEAD_S = 24e-6
"""One thread's time per step besides the particles' (records, the stop rule)."""

RUN_OVERHEAD_S = 0.05
"""A run's slot on a worker besides its steps where the workers never wait for a decision (verdict-mode
realisations, one run each): the scene and first mesh on the worker, its file, the transfer (the value
of the earlier fit, on which probabilistic_undrained's estimate was 0.93 of its wall at load <= 1)."""
SEARCH_RUN_OVERHEAD_S = 0.14
"""... in one of many cases' searches (a sweep, a probabilistic study in fos mode): besides the above,
the waits of the generations (a case handed out once the ones it is predicted from concluded).
(2 E - C) / R of studies/sweep_strength.toml, E its wall at load <= 1 (10.4 s, docs/benchmarks.md
"Run-time estimate", 2026-12-05) less ``STARTUP_S`` and its 9 estimates (0.2 s each), C its 29,373
steps by the step model: derived, not measured alone (``python -m benchmarks.startup_parts --study
sweep_strength`` measures it on an idle machine; it gave 0.71 s at load 9, when the lone search's
below gave 0.78 s)."""
LONE_SEARCH_WORKERS = 1.6
"""Workers a lone search (a single study, each time of the FOS against time, each level of a refinement
study but the repeated one) keeps busy on 2: it runs only what its last runs decided, so one worker
idles while the other finishes the run the search waits for, for a share of its runs' time that grows
with their length.  Its elapsed time is C / LONE_SEARCH_WORKERS + R ``LONE_RUN_WAIT_S`` (C its runs'
worker time, R its runs): the fit through the quickstart (short runs) and
studies/published/griffiths_lane_ex4.toml (long ones), ``python -m benchmarks.startup_parts --lone
quickstart published/griffiths_lane_ex4`` (docs/benchmarks.md "Run-time estimate")."""
LONE_RUN_WAIT_S = 0.10
"""... and each of its runs' wait for the decision that starts it, besides ``RUN_OVERHEAD_S`` (the same fit)."""

GRAVITY_S_PER_PARTICLE = 70e-6
"""A gravity state's time per particle: the elastic stage's direct solves (0.05 s at 669 particles, 0.13
s at 2,536, 0.49 s at 6,927: ``python -m benchmarks.relaxation_steps``, docs/benchmarks.md "Steps to a
quasi-static state"; with its scene: part "gravity" of ``python -m benchmarks.startup_parts``)."""

FIGURES_S = 0.6
"""A case's figures (its SRF curve, the fields at two runs, the slip surface) once pyplot is loaded: the
processor time of drawing them (0.57 s; ``python -m benchmarks.startup_parts``, "figures of a case",
whose wall was 1.5-2.6 s at load 9), a study of the FOS against time draws them at each time."""

FULL_SEARCH_RUNS = (6, 3)
"""(stable, failed) runs of a search over the stage's SRF range (the shipped studies make 8 to 12); a
window that misses grows by doubling and then refines as a full search does: it costs as much
(drawdown 8.8 and seismic 10 runs per FOS, docs/benchmarks.md "Runs per answer")."""
WINDOW_RUNS = (3, 1.6)
"""... of a search in a window about a predicted FOS (``fos.prediction``: a sweep's cases after the
first, a probabilistic study's realisations in fos mode, a refinement study's levels after the first;
4.6 runs per FOS on studies/sweep_strength.toml)."""
VARIABLE_WINDOW_RUNS = (2.1, 1.1)
"""... of a realisation of random variables in fos mode, predicted by the fit over the realisations before it
(its variables as features): studies/probabilistic_c_phi.toml's 39 realisations after the first made 2.08
stable and 1.10 failed runs each, counted in their summaries (131 runs in all; with WINDOW_RUNS, which a
sweep's few cases need, check estimated that study at 1.50 of its idle wall)."""
FIELD_WINDOW_RUNS = (2.7, 2.1)
"""... of a realisation of random fields, whose FOS is predicted less well: on the undrained random-field
study in fos mode (200 realisations), 2.74 stable and 2.10 failed runs per FOS found, counted in the
summaries of its searches (4.84 runs; docs/benchmarks.md "Runs per answer")."""
ADAPTIVE_LEVELS = 5
"""Levels an adaptive refinement study is expected to make (the quickstart's slope: 5; steep slopes at
high friction angles reach max_levels)."""

STARTUP_S = 4.7
"""Seconds of a study besides its SRF searches: Python and the imports, the numba cache, the cluster's
start and close, the scene, one gravity state, the summary, figures and report.  W - E of the
quickstart: W 6.4 s at load 0.2-1 (``python -m benchmarks.check_estimate``), E 1.7 s, its search at
load 0.3-1 (``python -m benchmarks.startup_parts`` prints both, and the parts: imports 1.6 s, the
cluster's start 2.0 s, the numba cache 0.26 s, the gravity state 0.18 s, the least of 3 at load 9)."""


@dataclass(frozen=True)
class ClientWork:
    """What ``check`` measures on this machine (processor time) of the work a study does in its own process, once:
    ``flow_s`` a solve of its water (the steady flow of ``[seepage]``, a transient flow to its last
    time), ``estimate_s`` a limit-equilibrium estimate (``fos.critical_circle(quick=True)``, what each
    predicted case asks), ``scene_s`` the study's scene on its solved water (``scene.scene_and_flow``), which
    the report's section figure builds again (``html_report``; the flow remembered) when the study draws
    figures."""

    flow_s: float = 0.0
    estimate_s: float = 0.0
    scene_s: float = 0.0


@dataclass(frozen=True)
class RunTimeEstimate:
    """What one SRF run and the study are expected to take (module doc)."""

    time_step_s: float  # dt ~ h_min / V_p
    response_time_s: float  # T = 4 H_domain / V_s with the runs' moduli
    stable_run_s: float
    failed_run_s: float
    cases: int | None  # factors of safety the study computes (None: a refinement study's levels)
    workers: int
    study_s: float
    full_searches: bool = False  # every case searched in full: its window would miss (:func:`windows_miss`)


def run_time_estimate(study: Study, scene, workers: int, client: ClientWork = ClientWork()) -> RunTimeEstimate | None:
    """The estimate of the module doc for a strength-reduction study (None for another) of ``scene``,
    with the ``client`` work check measured."""
    stage = study.strength_reduction
    if stage is None:
        return None
    n_particles = scene.n_particles
    factor = stage.stiffness_factor(scene.materials, study)
    time_step_s = study.geometry.finest_spacing_m / max(_p_wave_speed(m, factor) for m in study.materials)
    response_s = stage.response_time_s(study, factor)
    step_s = STEP_OVERHEAD_S + n_particles * SECONDS_PER_PARTICLE_STEP

    def run_s(response_times: float, particles: float = n_particles, finer: float = 1.0) -> float:
        """A run of ``particles`` whose time step is ``finer`` times shorter than the study's."""
        steps = min(response_times * response_s, stage.duration_s) / time_step_s * finer
        return RUN_OVERHEAD_S + steps * (STEP_OVERHEAD_S + particles * SECONDS_PER_PARTICLE_STEP)

    stable_s, failed_s = run_s(STABLE_RESPONSE_TIMES), run_s(FAILED_RESPONSE_TIMES)
    cases = case_count(study)
    gravities = worker_gravities(study)
    gravities_s = max(gravities - 1, 0) * n_particles * GRAVITY_S_PER_PARTICLE + gravities * client.flow_s
    workers = max(workers, 1)
    study_s = (STARTUP_S + client_s(study, n_particles, time_step_s, step_s, client)
               + study_runs_s(study, run_s, n_particles, workers) + gravities_s / workers)
    return RunTimeEstimate(time_step_s, response_s, stable_s, failed_s, cases, workers, study_s, windows_miss(study))


def client_s(study: Study, n_particles: int, time_step_s: float, step_s: float, client: ClientWork) -> float:
    """The study's own process's work besides ``STARTUP_S``, which the workers wait for: its water's
    solve (a sweep's cases solve theirs with their gravity states, on the workers: :func:`worker_gravities`),
    its limit-equilibrium estimates (a sweep's cases, a probabilistic study's realisations of random
    variables in fos mode; one for realisations of fields alone), the report's section figure's scene
    on its remembered water (a sweep's solved again) when the study draws figures, and for the FOS against time each time's gravity
    state and figures, and the runout of the time that failed (its steps on the threads of this
    process)."""
    total = (0.0 if study.sweep is not None else client.flow_s) + estimates(study) * client.estimate_s
    if study.output.figures:  # (a sweep's own study's flow was solved by none of its cases)
        total += client.flow_s if study.sweep is not None else client.scene_s
    transient = study.transient
    if transient is not None and transient.against_time:
        times = len(transient.fos_times())
        total += times * (n_particles * GRAVITY_S_PER_PARTICLE + (FIGURES_S if study.output.figures else 0.0))
        if transient.runout_duration_s is not None:
            total += transient.runout_duration_s / time_step_s * step_s
    return total


def estimates(study: Study) -> int:
    """The limit-equilibrium estimates a study's predictions ask of its process (``fos.prediction``, one
    per section, soil, water and loads): a sweep's cases, a fos-mode probabilistic study's realisations
    (one per study when only a random field varies), none otherwise."""
    if study.refinement is not None or (study.transient is not None and study.transient.against_time):
        return 0
    studies = len(sweep_cases(study)) if study.sweep is not None else 1
    if study.probabilistic is not None:
        if study.probabilistic.compute == "verdict":
            return 0
        return studies * (study.probabilistic.realisations if study.probabilistic.variables else 1)
    return studies if study.sweep is not None else 0


def worker_gravities(study: Study) -> int:
    """The gravity states a sweep's workers relax, each with its water's solve (the first one's relaxation
    is in ``STARTUP_S``): one per distinct ``fos.keys.gravity_key`` of its cases (the cases that share
    one share it); none for other studies (their own process relaxes theirs)."""
    if study.sweep is None or study.probabilistic is not None:
        return 0
    from workflows.fos.keys import gravity_key

    return len({gravity_key(case.study) for case in sweep_cases(study)})


def windows_miss(study: Study) -> bool:
    """Whether a sweep's cases differ in what the limit-equilibrium estimate does not see
    (``fos.critical_circle.NOT_SEEN``): the prediction then misses, and each case costs a full search."""
    from workflows.fos.critical_circle import NOT_SEEN

    return study.sweep is not None and any(axis.path.startswith(NOT_SEEN) for axis in study.sweep.axes)


def worker_time_s(runs: tuple[float, float], stable_s: float, failed_s: float) -> float:
    """C, the worker time of a search's (stable, failed) runs."""
    return runs[0] * stable_s + runs[1] * failed_s


def lone_search_s(runs: tuple[float, float], stable_s: float, failed_s: float, workers: int) -> float:
    """The elapsed time of a lone search: C / min(``LONE_SEARCH_WORKERS``, workers) + R ``LONE_RUN_WAIT_S``."""
    return (worker_time_s(runs, stable_s, failed_s) / min(LONE_SEARCH_WORKERS, workers)
            + sum(runs) * LONE_RUN_WAIT_S)


def many_searches_s(runs: tuple[float, float], stable_s: float, failed_s: float, workers: int) -> float:
    """A search's share of the elapsed time of many searches at once (sweeps, fos mode, a refinement
    level and its repeat), which keep every worker busy: (C + R (``SEARCH_RUN_OVERHEAD_S`` -
    ``RUN_OVERHEAD_S``)) / workers."""
    return (worker_time_s(runs, stable_s, failed_s) + sum(runs) * (SEARCH_RUN_OVERHEAD_S - RUN_OVERHEAD_S)) / workers


def study_runs_s(study: Study, run_s, n_particles: int, workers: int) -> float:
    """The elapsed time of a study's SRF runs on ``workers``: one full search per study, a sweep's first
    case and a refinement study's first level; windowed searches for the cases after the first (full
    ones where the windows miss: :func:`windows_miss`); one run per realisation in verdict mode; a
    refinement study's levels at their own particles and time steps.  A lone search (a single study,
    each time of the FOS against time) waits for its decisions (:func:`lone_search_s`); many cases'
    searches at once keep the workers busy (:func:`many_searches_s`).  ``run_s(response_times,
    particles, finer)`` is a run's worker time."""
    stable_s, failed_s = run_s(STABLE_RESPONSE_TIMES), run_s(FAILED_RESPONSE_TIMES)
    if study.refinement is not None:
        return _refinement_runs_s(study, run_s, n_particles, workers)
    cases = case_count(study)
    if study.probabilistic is not None:
        if not study.probabilistic.computation.searches:
            return cases * stable_s / workers
        later = FIELD_WINDOW_RUNS if study.random_field is not None else VARIABLE_WINDOW_RUNS
        studies = len(sweep_cases(study)) if study.sweep is not None else 1  # each its first search in full
        return (studies * many_searches_s(FULL_SEARCH_RUNS, stable_s, failed_s, workers)
                + (cases - studies) * many_searches_s(later, stable_s, failed_s, workers))
    if study.sweep is None:  # one search, or the times of the FOS against time one after another
        return (lone_search_s(FULL_SEARCH_RUNS, stable_s, failed_s, workers)
                + (cases - 1) * lone_search_s(WINDOW_RUNS, stable_s, failed_s, workers))
    later = FULL_SEARCH_RUNS if windows_miss(study) else WINDOW_RUNS
    return (many_searches_s(FULL_SEARCH_RUNS, stable_s, failed_s, workers)
            + (cases - 1) * many_searches_s(later, stable_s, failed_s, workers))


def _refinement_runs_s(study: Study, run_s, n_particles: int, workers: int) -> float:
    """The levels of a refinement study (``[refinement]``), one after another: a level at spacing h_k of
    n_k particles runs at n_k particles and a time step h_k / h_0 of the first level's; uniform levels
    hold n_0 (h_0 / h_k)^2 particles, adaptive ones add bands along the critical circle
    (``fos.critical_circle``), a reach of band_reach spacings of the level before on either side, at
    h_k.  Each level after the first relaxes its own gravity state in the study's process before its
    runs; level 1 runs twice at once (the scatter, with a jitter): two searches sharing the workers,
    every other level a lone search (:func:`lone_search_s`)."""
    from workflows.refinement.study_type import REPEAT_LEVEL

    table = study.refinement
    spacings = table.spacings(study.geometry.spacing_m)
    h0 = spacings[0]
    if table.adaptive:
        spacings = spacings[:min(ADAPTIVE_LEVELS, table.max_levels)]
        circle = critical_circle(study, quick=True)
        arc_m = (abs(circle.exit_x_m - circle.entry_x_m) * 1.2) if circle is not None else study.slope_height_m * 2.0
        particles = [n_particles + sum(arc_m * 2.0 * table.band_reach * spacings[j - 1] / spacings[j] ** 2
                                       for j in range(1, k + 1)) for k in range(len(spacings))]
    else:
        particles = [n_particles * (h0 / h) ** 2 for h in spacings]
    total = 0.0
    for k, (h, n) in enumerate(zip(spacings, particles)):
        stable_s = run_s(STABLE_RESPONSE_TIMES, n, h0 / h)
        failed_s = run_s(FAILED_RESPONSE_TIMES, n, h0 / h)
        runs = FULL_SEARCH_RUNS if k == 0 else WINDOW_RUNS
        repeated = k == REPEAT_LEVEL and table.jitter > 0
        if repeated:
            total += 2 * many_searches_s(runs, stable_s, failed_s, workers)
        else:
            total += lone_search_s(runs, stable_s, failed_s, workers)
        if k > 0:
            total += (2 if repeated else 1) * n * GRAVITY_S_PER_PARTICLE
    return total


def case_count(study: Study) -> int | None:
    """The factors of safety a study computes: one, a sweep's cases, the realisations (the point estimate
    method's 2^n points; FORM's and subset simulation's at most: they stop when converged), the times
    of the FOS against time (at most: it may stop early); None for a refinement study (a factor at each
    of its levels)."""
    if study.refinement is not None:
        return None
    if study.transient is not None and study.transient.against_time:
        return len(study.transient.fos_times())
    if study.probabilistic is not None:  # (with [sweep]: a probabilistic study per case)
        table = study.probabilistic
        each = table.method_kind.most_searches(table, len(table.variables))
        return each * (len(sweep_cases(study)) if study.sweep is not None else 1)
    if study.sweep is not None:
        return len(sweep_cases(study))
    return 1


def _p_wave_speed(material, factor: float) -> float:
    """V_p = sqrt(M / rho), M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), of a material with E times ``factor``."""
    e_pa, nu = material.youngs_modulus_pa * factor, material.poisson_ratio
    return math.sqrt(e_pa * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu)) / material.density_kg_m3)


@dataclass(frozen=True)
class StudyCheck:
    """What ``spfem-fos check`` found."""

    n_particles: int
    memory_bytes: float  # one simulation's peak
    processes: int  # simulations held at once (the client and each local worker)
    estimate: RunTimeEstimate | None
    section_png: Path
    flow: object = None  # the steady flow of [seepage] (``workflows.seepage.flow.StudyFlow``), or None
    critical: CriticalCircle | None = None  # the critical circle of a limit-equilibrium search (fos.critical_circle), if any
    warnings: tuple[str, ...] = ()  # the domain too short for it (fos.critical_circle.domain_warnings), field notes
    client: ClientWork = ClientWork()  # the study's own work as check measured it (:func:`client_work`)

    def lines(self) -> list[str]:
        """What the command prints."""
        gib = self.memory_bytes / 1024.0**3
        lines = [f"{self.n_particles} particles; about {gib:.2g} GiB per simulation"
                 + (f", {gib * self.processes:.2g} GiB for the {self.processes} processes of the study"
                    if self.processes > 1 else "")]
        if self.estimate is not None:
            e = self.estimate
            lines.append(f"SRF runs: time step about {e.time_step_s:.3g} s, response time {e.response_time_s:.3g} s; "
                         f"a run about {_seconds(e.stable_run_s)} (at rest) to {_seconds(e.failed_run_s)} (sliding) "
                         "on one core")
            what = ("levels of refinement" if e.cases is None else "one FOS" if e.cases == 1
                    else f"{e.cases} factors of safety, each searched in full (their predictions do not see what "
                         "the cases differ in)" if e.full_searches
                    else f"{e.cases} factors of safety, searched about their predicted values after the first")
            lines.append(f"the study: about {_seconds(e.study_s)} ({what}, on {e.workers} worker{'s' * (e.workers > 1)})")
        if self.flow is not None:
            lines.append(self.flow.line() if isinstance(self.flow, WaterAt) else flow_line(self.flow))
        if self.critical is not None:
            c = self.critical
            lines.append(f"limit equilibrium (Bishop's circles, {c.water}): F about {c.fos:.3g} on a circle from x = "
                         f"{min(c.entry_x_m, c.exit_x_m):.4g} to {max(c.entry_x_m, c.exit_x_m):.4g} m (where the "
                         "mechanism should form; the strength reduction gives the FOS)")
        lines += list(self.warnings)
        lines.append(f"wrote {self.section_png}")
        return lines


def _seconds(value_s: float) -> str:
    return f"{value_s:.2g} s" if value_s < 60.0 else f"{value_s / 60.0:.2g} min"


def client_work(study: Study, flow, solve_s: float, scene_s: float) -> ClientWork:
    """The :class:`ClientWork` of ``study`` measured here, in processor time (its wall on an idle machine,
    as every constant of the estimate: a loaded machine slows the study and check alike): its water's
    solve as check made it (``solve_s``, with the scene's build ``scene_s``), for the FOS against time
    the transient flow solved again to its last time, as the run solves it; one limit-equilibrium
    estimate when the study's predictions ask for any (:func:`estimates`); the scene on its water
    (``scene_s``), which the report builds again (its flow remembered: ``scene.water_flow``)."""
    flow_s = solve_s + scene_s if flow is not None else 0.0
    if isinstance(flow, WaterAt) and study.transient.against_time:
        start = time.process_time()
        transient_flow(study, until_h=study.transient.end_time_h)
        flow_s = time.process_time() - start
    estimate_s = 0.0
    if estimates(study):
        start = time.process_time()
        try:
            critical_circle(study, quick=True)
        except (ValueError, IndexError, ZeroDivisionError):  # (the prediction then has none: as costly)
            pass
        estimate_s = time.process_time() - start
    return ClientWork(flow_s, estimate_s, scene_s)


SECTION_FIGURE = "section.png"
"""The picture ``spfem-fos check`` draws in the output folder."""


def check_study(study: Study, kind, out_dir: Path, options) -> StudyCheck:
    """The run's checks of ``study`` of type ``kind`` (a ``cases.StudyType``) with the run's ``options``
    (module doc; a refusal is its StudyError), then the section drawn into ``out_dir`` with the critical
    circle of a limit-equilibrium search (``fos.critical_circle``), and the run estimated."""
    kind.check(options)
    kind.check_every_case()
    start_s = time.process_time()
    flow = water_flow(study)
    solve_s = time.process_time() - start_s
    scene, flow = scene_and_flow(study, flow)
    scene_s = time.process_time() - start_s - solve_s
    monitor_particles(study, scene)
    new_simulation(study, scene)
    make_output_folder(out_dir)
    critical = critical_circle(study) if study.strength_reduction is not None else None
    path = draw_section(study, scene, out_dir / SECTION_FIGURE, critical, flow)
    client = client_work(study, flow, solve_s, scene_s) if study.strength_reduction is not None else ClientWork()
    return StudyCheck(scene.n_particles, scene.n_particles * BYTES_PER_PARTICLE, kind.processes(options),
                      run_time_estimate(study, scene, options.workers, client), path, flow, critical,
                      (tuple(domain_warnings(study, critical)) if critical is not None else ())
                      + tuple(random_field_notes(study)), client)

