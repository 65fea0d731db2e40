"""``spfem-fos check``: a study looked at without running it (workflows.check)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from workflows.check import (
    FIGURES_S,
    FULL_SEARCH_RUNS,
    GRAVITY_S_PER_PARTICLE,
    LONE_RUN_WAIT_S,
    LONE_SEARCH_WORKERS,
    RUN_OVERHEAD_S,
    SEARCH_RUN_OVERHEAD_S,
    SECONDS_PER_PARTICLE_STEP,
    STARTUP_S,
    STEP_OVERHEAD_S,
    WINDOW_RUNS,
    ClientWork,
    run_time_estimate,
)
from workflows.output.figures import drawn_by_us
from workflows.scene import build_scene
from workflows.study import load_study, parse_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = REPO / "studies" / "quickstart.toml"


def spfem_fos(*args, cwd=REPO):
    """The command as a user runs it, this tree's sources first (from any folder)."""
    return subprocess.run([sys.executable, "-m", "workflows.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=dict(os.environ, PYTHONPATH=str(REPO)))


def test_check_draws_the_section_and_counts_without_running(tmp_path):
    done = spfem_fos("check", QUICKSTART, "--out", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    n = build_scene(load_study(QUICKSTART)).n_particles
    assert lines[0].startswith(f"{n} particles; about ")
    assert lines[1].startswith("SRF runs: time step about ") and lines[2].startswith("the study: about ")
    assert lines[-1] == f"wrote {tmp_path / 'out' / 'section.png'}"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["section.png"]  # no run, no lock left
    assert drawn_by_us(tmp_path / "out" / "section.png")


@pytest.mark.parametrize("args, line", [
    (["check", "missing.toml"], "error: missing.toml: no such file"),
    (["check", QUICKSTART, "--bogus"], "error: No such option: --bogus"),
    (["check"], "error: Missing argument 'STUDY.toml'."),
])
def test_check_usage_and_file_errors_are_one_line_exit_2(args, line, tmp_path):
    done = spfem_fos(*args, cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith(line) and done.stderr.count("\n") == 1, done.stderr
    assert list(tmp_path.iterdir()) == []


def test_check_refuses_what_the_scene_refuses_and_writes_nothing(tmp_path):
    """A study whose scene is refused (a wall through the soil) is refused by check as by a run."""
    text = QUICKSTART.read_text().replace(
        "[solver]", '[[walls]]\nname = "cut"\nstart_m = [10.0, 20.0]\nend_m = [10.0, -5.0]\n\n[solver]', 1)
    study = tmp_path / "study.toml"
    study.write_text(text)
    done = spfem_fos("check", study, "--out", tmp_path / "out")
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"error: {study}: walls[0]: ") and done.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_the_estimate_follows_its_model():
    """dt = h / V_p and T = 4 H_domain / V_s with the runs' moduli (the quickstart's are scaled by
    the stiffness factor); a run is RUN_OVERHEAD_S plus its steps; a lone search keeps LONE_SEARCH_WORKERS
    busy and waits LONE_RUN_WAIT_S a run, many cases' searches keep both busy and wait SEARCH_RUN_OVERHEAD_S
    a run; a sweep of k cases costs one full search and k - 1 searches in predicted windows; a
    verdict-mode realisation one run."""
    study = load_study(QUICKSTART)
    scene = build_scene(study)
    estimate = run_time_estimate(study, scene, workers=2)
    stage = study.strength_reduction
    factor = stage.stiffness_factor(scene.materials, study)
    soil = study.materials[0]
    e_pa, nu, rho = factor * soil.youngs_modulus_pa, soil.poisson_ratio, soil.density_kg_m3
    assert estimate.time_step_s == pytest.approx(1.0 / math.sqrt(e_pa * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho))
    assert estimate.response_time_s == pytest.approx(4.0 * 15.0 / math.sqrt(e_pa / (2 * (1 + nu)) / rho))
    assert RUN_OVERHEAD_S < estimate.stable_run_s < estimate.failed_run_s
    full_s = FULL_SEARCH_RUNS[0] * estimate.stable_run_s + FULL_SEARCH_RUNS[1] * estimate.failed_run_s
    window_s = WINDOW_RUNS[0] * estimate.stable_run_s + WINDOW_RUNS[1] * estimate.failed_run_s
    lone_s = full_s / LONE_SEARCH_WORKERS + sum(FULL_SEARCH_RUNS) * LONE_RUN_WAIT_S  # a single study's lone search
    assert estimate.study_s == pytest.approx(STARTUP_S + lone_s)
    swept = parse_study(QUICKSTART.read_text() + '\n[sweep]\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\n'
                        'values = [8e3, 10e3, 12e3]\n')  # (one gravity state: an elastic stage ignores the strength)
    search_wait_s = (sum(FULL_SEARCH_RUNS) + 2 * sum(WINDOW_RUNS)) * (SEARCH_RUN_OVERHEAD_S - RUN_OVERHEAD_S)
    assert run_time_estimate(swept, scene, workers=2).study_s == pytest.approx(
        STARTUP_S + (full_s + 2 * window_s + search_wait_s) / 2)
    measured = ClientWork(estimate_s=0.25)  # its three limit-equilibrium estimates, in the study's process
    assert run_time_estimate(swept, scene, 2, measured).study_s == pytest.approx(
        STARTUP_S + 3 * 0.25 + (full_s + 2 * window_s + search_wait_s) / 2)
    verdicts = parse_study((REPO / "studies" / "probabilistic_undrained.toml").read_text())
    verdict_scene = build_scene(verdicts)
    one = run_time_estimate(verdicts, verdict_scene, workers=2)
    assert one.study_s == pytest.approx(STARTUP_S + 200 * one.stable_run_s / 2)


def test_a_study_without_strength_reduction_has_no_run_estimate(tmp_path):
    done = spfem_fos("check", REPO / "studies" / "cantilever_beam.toml", "--out", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    assert "SRF runs" not in done.stdout and done.stdout.splitlines()[-1].endswith("section.png")


PROBABILISTIC = "\n[probabilistic]\nrealisations = 20\n"


def _variable(path: str, distribution: str, extra: str) -> str:
    return f'\n[[probabilistic.variables]]\npath = "{path}"\ndistribution = "{distribution}"\n{extra}\n'


@pytest.mark.parametrize("change, options, field", [
    pytest.param(PROBABILISTIC + "correlation = [[1.0, 0.9, -0.9], [0.9, 1.0, 0.9], [-0.9, 0.9, 1.0]]"
     + _variable("materials.soil.cohesion_pa", "normal", "cov = 0.1")
     + _variable("materials.soil.friction_deg", "normal", "cov = 0.1")
     + _variable("materials.soil.youngs_modulus_pa", "normal", "cov = 0.1"), {}, "probabilistic.correlation",
     id="correlation-of-three-normals-no-covariance-has"),
    pytest.param(PROBABILISTIC + "correlation = [[1.0, -0.9], [-0.9, 1.0]]"
     + _variable("materials.soil.cohesion_pa", "lognormal", "cov = 2.0")
     + _variable("materials.soil.youngs_modulus_pa", "lognormal", "cov = 2.0"), {}, "probabilistic.correlation",
     id="correlation-two-lognormals-cannot-reach"),
    pytest.param(PROBABILISTIC + _variable("materials.soil.cohesion_pa", "uniform", "low = -1e3\nhigh = 2e4"), {},
                 "probabilistic.variables[0].low", id="bounds-outside-the-range"),
    pytest.param(PROBABILISTIC + _variable("materials.soil.cohesion_pa", "normal", "cov = 1.0"), {},
                 "probabilistic.variables[0]", id="normal-strength-drawing-negative-values"),
    pytest.param("", {"max_memory_bytes": 0.004 * 1024**3}, "geometry.spacing_m",
                 id="memory-of-the-run-s-three-processes"),
    pytest.param("", {"max_duration_s": 0.01}, "stages[0].max_duration_s", id="stage-of-fewer-steps-than-the-core-takes"),
    pytest.param("", {"spacing_m": 4.0}, "geometry.spacing_m", id="spacing-too-coarse-for-the-slope"),
])
def test_check_refuses_what_the_run_refuses_before_its_first_step_with_the_same_line(change, options, field, tmp_path):
    """``spfem-fos check`` makes every check the run makes before its first step, with the run's options
    (here: two workers and a memory limit): each of these studies, which check passed before, is now
    refused by both with the same line."""
    from workflows.cases import RunOptions
    from workflows.check import check_study
    from workflows.study import StudyError
    from workflows.study_types import run_study, study_type

    text = QUICKSTART.read_text() + change
    if "max_duration_s" in options:
        text = text.replace("max_duration_s = 20.0", f"max_duration_s = {options.pop('max_duration_s')}").replace(
            "record_interval_s = 0.05", "record_interval_s = 0.001")
    if "spacing_m" in options:
        text = text.replace("spacing_m = 1.0", f"spacing_m = {options.pop('spacing_m')}")
    study = parse_study(text)
    lines = []
    for name, call in (("check", lambda out: check_study(study, study_type(study, out), out, RunOptions(**options))),
                       ("run", lambda out: run_study(study, out, RunOptions(**options)))):
        with pytest.raises(StudyError) as error:
            call(tmp_path / name)
        lines.append(str(error.value))
    assert lines[0] == lines[1] and lines[0].startswith(f"{field}: "), lines
    assert not (tmp_path / "check").exists() and not (tmp_path / "run" / "cases").exists()


def test_check_makes_every_realisation_and_refuses_the_one_the_run_would_stop_at(tmp_path):
    """Realisations are made only as they are about to run; a draw that breaks a rule between tables
    (a density that makes the soil float below the water table) stops the run when its realisation is
    made, after those before it ran.  check makes every realisation and refuses the same one with the
    same line, before anything runs."""
    from workflows.cases import RunOptions
    from workflows.check import check_study
    from workflows.study import StudyError
    from workflows.study_types import run_study, study_type

    text = (QUICKSTART.read_text().replace("[loads]", "[water]\nphreatic_level_m = 8.0\n\n[loads]")
            + "\n[probabilistic]\nrealisations = 40\nseed = 2\n"
            + _variable("materials.soil.density_kg_m3", "normal", "mean = 1300.0\nstd = 150.0"))
    study = parse_study(text)
    lines = []
    for name, call in (("check", lambda out: check_study(study, study_type(study, out), out, RunOptions())),
                       ("run", lambda out: run_study(study, out, RunOptions()))):
        with pytest.raises(StudyError) as error:
            call(tmp_path / name)
        lines.append(str(error.value))
    assert lines[0] == lines[1] and lines[0].startswith("probabilistic: realisation "), lines
    stopped_at = int(lines[0].split("realisation ")[1].split(":")[0])
    assert "would float" in lines[0] and stopped_at >= 2
    assert not (tmp_path / "check").exists()
    assert len(list((tmp_path / "run" / "cases").glob("*/srf_*.nc"))) >= 2  # the run stopped part way


def test_check_on_the_command_line_says_what_the_run_says(tmp_path):
    """The same study and options on the command line: both exit 2 with the same line."""
    done = [spfem_fos(*command, QUICKSTART, "--out", tmp_path / name, "--max-memory", "0.004")
            for name, command in (("check", ["check"]), ("run", []))]
    assert [each.returncode for each in done] == [2, 2], [each.stderr for each in done]
    assert done[0].stderr == done[1].stderr and done[0].stderr.count("\n") == 1
    assert "geometry.spacing_m" in done[0].stderr and "in each of 3 processes" in done[0].stderr


def test_a_sweep_of_probabilistic_studies_counts_every_cases_realisations():
    """Before: the estimate of studies/probabilistic_undrained_cov.toml (4 cases of 100 realisations)
    counted 100 runs and was a third of the measured time; a study per case, each its realisations."""
    from workflows.check import case_count
    from workflows.study.reading import sweep_cases

    study = load_study(REPO / "studies" / "probabilistic_undrained_cov.toml")
    assert case_count(study) == study.probabilistic.realisations * len(sweep_cases(study)) > 100


def test_a_sweep_the_limit_equilibrium_estimate_is_blind_to_counts_full_searches_and_its_gravity_states():
    """Before: studies/seismic.toml was estimated at 0.48 of its measured time, studies/drawdown.toml at
    0.38: their cases differ in a seismic load, in ponded water, which the estimate the windows rest on
    does not see (``fos.critical_circle.NOT_SEEN``); each window missed and each case made a full
    search (8.8 and 10 runs per FOS), and each case relaxed its own gravity state on the workers."""
    study = load_study(QUICKSTART)
    scene = build_scene(study)
    one = run_time_estimate(study, scene, workers=2)
    full_s = FULL_SEARCH_RUNS[0] * one.stable_run_s + FULL_SEARCH_RUNS[1] * one.failed_run_s
    seismic = parse_study(QUICKSTART.read_text() + '\n[loads.seismic]\nhorizontal_coefficient = 0.0\n'
                          '\n[sweep]\n[[sweep.axes]]\npath = "loads.seismic.horizontal_coefficient"\n'
                          'values = [0.0, 0.1, 0.2]\n')
    gravities_s = 2 * scene.n_particles * GRAVITY_S_PER_PARTICLE  # three states, the first in STARTUP_S
    search_wait_s = 3 * sum(FULL_SEARCH_RUNS) * (SEARCH_RUN_OVERHEAD_S - RUN_OVERHEAD_S)
    assert run_time_estimate(seismic, scene, workers=2).study_s == pytest.approx(
        STARTUP_S + (3 * full_s + search_wait_s + gravities_s) / 2)


def test_the_water_a_study_solves_is_counted_as_check_measured_it(tmp_path):
    """Before: studies/seepage_perched.toml was estimated at 0.34 of its measured time: its steady flow
    (most of the study) was not counted; then at 0.68: the report's section figure builds the scene
    and solves the flow again (``html_report``), which was not counted.  Check solves the same flow as
    the run, in a process like the run's own: its processor time is the estimate's, twice for a study
    that draws figures.  Now the flow is solved once per process (``scene.water_flow``): the report builds
    the scene again on it, counted without the solve."""
    from workflows.cases import RunOptions
    from workflows.check import check_study
    from workflows.study_types import study_type

    study = load_study(REPO / "studies" / "seepage_dam.toml")
    found = check_study(study, study_type(study, tmp_path), tmp_path, RunOptions(workers=2))
    assert found.client.flow_s > 0.0 and found.client.estimate_s == 0.0  # (a single study makes no prediction)
    assert 0.0 < found.client.scene_s < found.client.flow_s and study.output.figures
    scene = build_scene(study)
    dry = run_time_estimate(study, scene, workers=2)
    assert found.estimate.study_s == pytest.approx(dry.study_s + found.client.flow_s + found.client.scene_s)
    no_figures = parse_study(study.source_text + "\n[output]\nfigures = false\n")
    assert run_time_estimate(no_figures, scene, 2, found.client).study_s == pytest.approx(
        dry.study_s + found.client.flow_s)


def test_the_fos_against_time_counts_each_times_gravity_state_figures_and_runout():
    """Before: a study of the FOS against time (studies/rain.toml) was estimated as a sweep of its
    times: each time's gravity state and figures, made in the study's process between the times'
    searches, and the runout of the time that failed were not counted."""
    study = load_study(REPO / "studies" / "rain.toml")
    scene = build_scene(study)
    estimate = run_time_estimate(study, scene, workers=2, client=ClientWork(flow_s=2.0))
    times = len(study.transient.fos_times())
    full_s = FULL_SEARCH_RUNS[0] * estimate.stable_run_s + FULL_SEARCH_RUNS[1] * estimate.failed_run_s
    window_s = WINDOW_RUNS[0] * estimate.stable_run_s + WINDOW_RUNS[1] * estimate.failed_run_s
    searches_s = ((full_s + (times - 1) * window_s) / LONE_SEARCH_WORKERS
                  + (sum(FULL_SEARCH_RUNS) + (times - 1) * sum(WINDOW_RUNS)) * LONE_RUN_WAIT_S)
    each_time_s = scene.n_particles * GRAVITY_S_PER_PARTICLE + (FIGURES_S if study.output.figures else 0.0)
    step_s = (estimate.stable_run_s - RUN_OVERHEAD_S) / (min(3.0 * estimate.response_time_s,
                                                             study.strength_reduction.duration_s) / estimate.time_step_s)
    runout_s = study.transient.runout_duration_s / estimate.time_step_s * step_s
    assert estimate.study_s == pytest.approx(STARTUP_S + 2.0 + times * each_time_s + runout_s + searches_s)


def test_a_refinement_studys_levels_run_at_their_own_particles_and_steps_one_after_another():
    """Before: studies/fos_controlled.toml was estimated at 1.40 of its measured time, refinement_levels
    at 1.17: a level's runs cost the first level's times (n_k / n_0) (h_0 / h_k), a run's fixed
    RUN_OVERHEAD_S and the first level's per-step cost scaled with them, and the repeated level and its
    twin were counted as lone searches.  A level's run is RUN_OVERHEAD_S plus its steps, K T / dt_k with
    dt_k = dt_0 h_k / h_0, at STEP_OVERHEAD_S + n_k SECONDS_PER_PARTICLE_STEP each; level 1 and its repeat
    are two searches sharing the workers; every level after the first relaxes its gravity state in the
    study's process."""
    study = load_study(REPO / "studies" / "refinement_levels.toml")
    scene = build_scene(study)
    estimate = run_time_estimate(study, scene, workers=2)
    n0 = scene.n_particles
    steps0 = [(run_s - RUN_OVERHEAD_S) / (STEP_OVERHEAD_S + n0 * SECONDS_PER_PARTICLE_STEP)
              for run_s in (estimate.stable_run_s, estimate.failed_run_s)]
    spacings = study.refinement.spacings(study.geometry.spacing_m)
    assert study.refinement.jitter > 0.0 and len(spacings) == 4
    expected_s = STARTUP_S
    for k, h in enumerate(spacings):
        n = n0 * (spacings[0] / h) ** 2
        stable_s, failed_s = (RUN_OVERHEAD_S + steps * spacings[0] / h * (STEP_OVERHEAD_S + n * SECONDS_PER_PARTICLE_STEP)
                              for steps in steps0)
        runs = FULL_SEARCH_RUNS if k == 0 else WINDOW_RUNS
        worker_s = runs[0] * stable_s + runs[1] * failed_s
        if k == 1:  # and its repeat, at once
            expected_s += 2 * (worker_s + sum(runs) * (SEARCH_RUN_OVERHEAD_S - RUN_OVERHEAD_S)) / 2
            expected_s += 2 * n * GRAVITY_S_PER_PARTICLE
        else:
            expected_s += worker_s / LONE_SEARCH_WORKERS + sum(runs) * LONE_RUN_WAIT_S
            expected_s += n * GRAVITY_S_PER_PARTICLE if k > 0 else 0.0
    assert estimate.study_s == pytest.approx(expected_s)


def test_the_point_estimate_method_counts_its_two_to_the_n_points():
    """Before: a point-estimate study was estimated at its ``realisations`` (the most searches it may
    make), 25 here, where it makes the 2^n = 4 of Rosenblueth's points."""
    from workflows.check import case_count

    text = (QUICKSTART.read_text() + '\n[probabilistic]\nmethod = "point_estimate"\nrealisations = 25\ncompute = "fos"\n'
            + _variable("materials.soil.cohesion_pa", "normal", "cov = 0.1")
            + _variable("materials.soil.friction_deg", "normal", "cov = 0.05"))
    assert case_count(parse_study(text)) == 4


def test_a_studys_flow_is_solved_once_in_a_process(monkeypatch):
    """The report's section figure, drawn after the run, built the scene and solved the study's steady flow
    again (seepage_perched: 4.5 s of its 17 s); an equal study (the report's, parsed from the same text) is
    now the same flow."""
    import workflows.scene as scene_module

    solves = []
    solve = scene_module.study_flow
    monkeypatch.setattr(scene_module, "study_flow", lambda study: solves.append(1) or solve(study))
    scene_module.water_flow.cache_clear()
    text = (REPO / "studies" / "seepage_dam.toml").read_text()
    first = scene_module.scene_and_flow(parse_study(text))[1]
    again = scene_module.scene_and_flow(parse_study(text))[1]
    assert again is first and len(solves) == 1
    other = scene_module.scene_and_flow(parse_study(text.replace("spacing_m = 0.25", "spacing_m = 0.5")))[1]
    assert other is not first and len(solves) == 2  # another study: its own flow
    scene_module.water_flow.cache_clear()


def test_a_probabilistic_study_of_random_variables_counts_its_own_measured_windows(monkeypatch):
    """Its realisations are predicted by a fit over many before them: 3.2 runs a window on
    studies/probabilistic_c_phi.toml, where a sweep's few cases need 4.6 (``WINDOW_RUNS``), with which the
    study was estimated at 1.50 of its idle wall.  Its windows are VARIABLE_WINDOW_RUNS; a sweep's are not."""
    import workflows.check as check

    assert sum(check.VARIABLE_WINDOW_RUNS) < sum(check.WINDOW_RUNS)
    probabilistic = load_study(REPO / "studies" / "probabilistic_c_phi.toml")
    swept = load_study(REPO / "studies" / "sweep_strength.toml")
    scenes = {id(study): build_scene(study) for study in (probabilistic, swept)}
    before = {id(s): run_time_estimate(s, scenes[id(s)], workers=2).study_s for s in (probabilistic, swept)}
    monkeypatch.setattr(check, "VARIABLE_WINDOW_RUNS", (10.0, 0.0))
    assert run_time_estimate(probabilistic, scenes[id(probabilistic)], workers=2).study_s > before[id(probabilistic)]
    assert run_time_estimate(swept, scenes[id(swept)], workers=2).study_s == before[id(swept)]
