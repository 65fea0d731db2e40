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
``FULL_SEARCH_RUNS`` (stable, failed) runs, one in a predicted window ``WINDOW_RUNS`` (random fields:
``FIELD_WINDOW_RUNS``), a verdict-mode realisation one; a refinement study's levels cost in
proportion to their particles and time steps (:func:`study_runs_s`).  The runs are shared by the
workers, after the start-up (Python, the cluster, the gravity stage and the figures: ``STARTUP_S``).  The constants were measured on the
reference slope on the machine the benchmarks ran on (docs/benchmarks.md, "Run-time estimate",
with the command that compares the estimate with the measured time of every shipped study).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from workflows.fos.critical_circle import CriticalCircle, critical_circle, domain_warnings
from workflows.memory_guard import BYTES_PER_PARTICLE
from workflows.output.writing import make_output_folder
from workflows.scene import monitor_particles, random_field_notes, scene_and_flow
from workflows.section_figure import draw_section
from workflows.seepage.results import flow_line
from workflows.stages.running import new_simulation
from workflows.study import Study
from workflows.study.reading import sweep_cases
from workflows.transient.flow import WaterAt

STABLE_RESPONSE_TIMES = 3.0
"""Pseudo-time of a run that comes to rest, in response times (module doc)."""

FAILED_RESPONSE_TIMES = 12.0
"""Pseudo-time of a run that slides, in response times."""

SECONDS_PER_PARTICLE_STEP = 76e-9
"""One thread's time per particle and step of a plastic relaxation step."""

STEP_OVERHEAD_S = 24e-6
"""One thread's time per step besides the particles' (records, the stop rule)."""

RUN_OVERHEAD_S = 0.05
"""A run's time besides its steps: the scene and first mesh on the worker, its file, the transfer."""

FULL_SEARCH_RUNS = (6, 3)
"""(stable, failed) runs of a search over the stage's SRF range (the shipped studies make 8 to 12)."""
WINDOW_RUNS = (3, 1.6)
"""... of a search in a window about a predicted FOS (``fos.prediction``: a sweep's cases after the
first, a probabilistic study's realisations in fos mode, a refinement study's levels after the first;
4.6 runs per FOS on studies/sweep_strength.toml)."""
FIELD_WINDOW_RUNS = (4, 2)
"""... of a realisation of random fields, whose FOS is predicted less well (6.1 runs per FOS on the
undrained random-field study in fos mode)."""
ADAPTIVE_LEVELS = 5
"""Levels an adaptive refinement study is expected to make (the quickstart's slope: 5; steep slopes at
high friction angles reach max_levels)."""

STARTUP_S = 4.0
"""Seconds of a study besides its SRF runs: Python, the cluster, the gravity stage, the figures."""


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


def run_time_estimate(study: Study, scene, workers: int) -> RunTimeEstimate | None:
    """The estimate of the module doc for a strength-reduction study (None for another) of ``scene``."""
    stage = study.strength_reduction
    if stage is None:
        return None
    n_particles = scene.n_particles
    factor = stage.stiffness_factor(scene.materials, study)
    time_step_s = study.geometry.finest_spacing_m / max(_p_wave_speed(m, factor) for m in study.materials)
    response_s = stage.response_time_s(study, factor)
    step_s = STEP_OVERHEAD_S + n_particles * SECONDS_PER_PARTICLE_STEP

    def run_s(response_times: float) -> float:
        return RUN_OVERHEAD_S + min(response_times * response_s, stage.duration_s) / time_step_s * step_s

    stable_s, failed_s = run_s(STABLE_RESPONSE_TIMES), run_s(FAILED_RESPONSE_TIMES)
    cases = case_count(study)
    study_s = STARTUP_S + study_runs_s(study, stable_s, failed_s, n_particles, time_step_s) / max(workers, 1)
    return RunTimeEstimate(time_step_s, response_s, stable_s, failed_s, cases, workers, study_s)


def study_runs_s(study: Study, stable_s: float, failed_s: float, n_particles: int, time_step_s: float) -> float:
    """The worker time of a study's SRF runs: one full search per study, a sweep's first case and a
    refinement study's first level; windowed searches for the cases after the first; one run per
    realisation in verdict mode; a refinement study's levels at their own particles and time steps."""
    def search(runs: tuple[float, float], scale: float = 1.0) -> float:
        return scale * (runs[0] * stable_s + runs[1] * failed_s)

    if study.refinement is not None:
        return _refinement_runs_s(study, search, n_particles, time_step_s)
    cases = case_count(study)
    if study.probabilistic is not None:
        if not study.probabilistic.computation.searches:
            return cases * stable_s
        later = FIELD_WINDOW_RUNS if study.random_field is not None else WINDOW_RUNS
        studies = len(sweep_cases(study)) if study.sweep is not None else 1  # each its first search in full
        return studies * search(FULL_SEARCH_RUNS) + (cases - studies) * search(later)
    return search(FULL_SEARCH_RUNS) + (cases - 1) * search(WINDOW_RUNS)


def _refinement_runs_s(study: Study, search, n_particles: int, time_step_s: float) -> float:
    """The levels of a refinement study (``[refinement]``): a run at level k costs the first level's times
    (particles_k / particles_0) (h_0 / h_k); uniform levels hold n_0 (h_0 / h_k)^2 particles, adaptive
    ones add bands along the critical circle (``fos.critical_circle``), a reach of band_reach spacings of
    the level before on either side, at h_k; level 1 runs twice (the scatter)."""
    table = study.refinement
    spacings = table.spacings(study.geometry.spacing_m)
    h0 = spacings[0]
    if table.adaptive:
        spacings = spacings[:min(ADAPTIVE_LEVELS, table.max_levels)]
        from workflows.fos.critical_circle import critical_circle

        circle = critical_circle(study, quick=True)
        arc_m = (abs(circle.exit_x_m - circle.entry_x_m) * 1.2) if circle is not None else study.slope_height_m * 2.0
        particles = [n_particles + sum(arc_m * 2.0 * table.band_reach * spacings[j - 1] / spacings[j] ** 2
                                       for j in range(1, k + 1)) for k in range(len(spacings))]
    else:
        particles = [n_particles * (h0 / h) ** 2 for h in spacings]
    total = 0.0
    for k, (h, n) in enumerate(zip(spacings, particles)):
        scale = (n / n_particles) * (h0 / h)
        total += search(FULL_SEARCH_RUNS if k == 0 else WINDOW_RUNS, scale) * (2 if k == 1 and table.jitter > 0 else 1)
    return total


def case_count(study: Study) -> int | None:
    """The factors of safety a study computes: one, a sweep's cases, the realisations, the times of the FOS
    against time (at most: it may stop early); None for a refinement study (a factor at each of its levels)."""
    if study.refinement is not None:
        return None
    if study.transient is not None and study.transient.against_time:
        return len(study.transient.fos_times())
    if study.probabilistic is not None:  # (with [sweep]: a probabilistic study per case)
        return study.probabilistic.realisations * (len(sweep_cases(study)) if study.sweep is not None else 1)
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


SECTION_FIGURE = "section.png"
"""The picture ``spfem-fos check`` draws in the output folder."""


def check_study(study: Study, kind, out_dir: Path, options) -> StudyCheck:
    """The run's checks of ``study`` of type ``kind`` (a ``cases.StudyType``) with the run's ``options``
    (module doc; a refusal is its StudyError), then the section drawn into ``out_dir`` with the critical
    circle of a limit-equilibrium search (``fos.critical_circle``), and the run estimated."""
    kind.check(options)
    kind.check_every_case()
    scene, flow = scene_and_flow(study)
    monitor_particles(study, scene)
    new_simulation(study, scene)
    make_output_folder(out_dir)
    critical = critical_circle(study) if study.strength_reduction is not None else None
    path = draw_section(study, scene, out_dir / SECTION_FIGURE, critical, flow)
    return StudyCheck(scene.n_particles, scene.n_particles * BYTES_PER_PARTICLE, kind.processes(options),
                      run_time_estimate(study, scene, options.workers), path, flow, critical,
                      (tuple(domain_warnings(study, critical)) if critical is not None else ())
                      + tuple(random_field_notes(study)))

