"""Probabilistic studies of random variables: the table's checks, realisations judged at a
factor, reproducible from the seed, and a study extended by computing only its new realisations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from workflows.cases import RunOptions
from workflows.distributions import LOGNORMAL
from workflows.probabilistic.sampling import Marginal, Sampler
from workflows.progress import Progress
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()
COHESION = '[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "lognormal"\ncov = 0.3\n'


class _Tally(Progress):
    def __init__(self):
        self.lines = []

    def tally(self, text):
        self.lines.append(text)


def probabilistic(count: int, extra: str = "") -> str:
    return QUICKSTART + f"\n[probabilistic]\nrealisations = {count}\nseed = 3\nfactor = 1.3\n{extra}\n" + COHESION


@pytest.mark.parametrize("block, field, message", [
    ('[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "normal"\nstd = 1e3\ncov = 0.1',
     "probabilistic.variables[0].std", "one of them"),
    ('[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "uniform"\nlow = 1e3',
     "probabilistic.variables[0].high", "low and high"),
    ('[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "normal"\ncov = 0.1\nlow = 0',
     "probabilistic.variables[0].low", "applies to uniform"),
    ('correlation = [[1.0, 0.5], [0.5, 1.0]]\n[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\n'
     'distribution = "normal"\ncov = 0.1', "probabilistic.correlation", "1 rows of 1"),
])
def test_bad_probabilistic_tables_name_the_field(block, field, message):
    with pytest.raises(StudyError) as error:
        parse_study(QUICKSTART + f"\n[probabilistic]\nrealisations = 10\n{block}\n")
    assert error.value.field == field and message in str(error.value)


def test_a_draw_the_field_refuses_is_named_with_its_realisation(tmp_path):
    """A normal cohesion of COV 1 draws negative values: the study stops before it runs, naming the
    realisation, the value and the remedy."""
    text = QUICKSTART + ('\n[probabilistic]\nrealisations = 50\n[[probabilistic.variables]]\n'
                         'path = "materials.soil.cohesion_pa"\ndistribution = "normal"\ncov = 1.0\n')
    with pytest.raises(StudyError) as error:
        run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert error.value.field == "probabilistic.variables[0]" and "truncated_normal" in str(error.value)
    assert not (tmp_path / "probabilistic.nc").exists()


def test_realisations_are_judged_at_the_factor_and_an_extended_study_computes_only_the_new_ones(tmp_path):
    """Lognormal cohesion (COV 0.3) on the quickstart, each realisation one run at F = 1.3: the
    values are the sampler's, every failed cohesion lies below every stable one (the FOS rises with
    c), pf is the fraction failed, the progress tallies each realisation as it concludes; extended from 8 to 12 realisations, the first 8 are reused and
    keep their verdicts."""
    progress = _Tally()
    first = run_study(parse_study(probabilistic(8)), tmp_path, RunOptions(workers=2), progress=progress)
    ds = xr.load_dataset(tmp_path / "probabilistic.nc")
    expected = Sampler([Marginal(LOGNORMAL, 10e3, 3e3)]).monte_carlo(3, range(8))[:, 0]
    np.testing.assert_allclose(ds["cohesion_pa"].values, expected, rtol=1e-12)
    verdicts = ds["verdict"].values
    assert set(verdicts) <= {"stable", "failed"}
    cohesion = ds["cohesion_pa"].values
    assert "failed" in verdicts and "stable" in verdicts  # seed 3: 2 of 8 fail
    assert cohesion[verdicts == "failed"].max() < cohesion[verdicts == "stable"].min()
    assert ds.attrs["pf"] == pytest.approx(np.mean(verdicts == "failed"))
    failure_m = 0.005 * 10.0  # 0.5% of the slope height
    assert list(ds["n_runs"].values) == [1] * 8 and (ds["n_steps"].values > 0).all()
    assert ((ds["max_displacement"].values > failure_m) == (verdicts == "failed")).all()
    assert list(ds["particle_fields"].values) == list(verdicts == "failed")  # keep_fields = "failed"
    assert ds.attrs["pf_low"] <= ds.attrs["pf"] <= ds.attrs["pf_high"]
    # the failed realisations' slip lines: a toe mechanism each, and their envelope
    assert ds["slip_envelope_x"].attrs["n_lines"] == np.sum(verdicts == "failed")
    assert ds["slip_envelope_count"].max() == np.sum(verdicts == "failed")
    lower, upper = ds["slip_envelope_lower"].values, ds["slip_envelope_upper"].values
    reached = ds["slip_envelope_count"].values > 0
    assert np.all(lower[reached] <= upper[reached]) and 0.0 <= np.nanmin(lower) < 5.0
    assert (tmp_path / "slip_envelope.png").is_file()
    assert first.runs_made == 8
    n_failed = int(np.sum(verdicts == "failed"))
    assert len(progress.lines) == 8 and progress.lines[-1] == f"{n_failed} failed, pf {n_failed / 8:.3g}"
    extended = run_study(parse_study(probabilistic(12)), tmp_path, RunOptions(workers=2))
    assert extended.runs_made == 4
    more = xr.load_dataset(tmp_path / "probabilistic.nc")
    assert list(more["verdict"].values[:8]) == list(verdicts)
    np.testing.assert_array_equal(more["cohesion_pa"].values[:8], cohesion)


def test_a_sweep_of_probabilistic_studies_gives_each_case_its_own_pf(tmp_path):
    """[sweep] over the friction angle of a probabilistic study (lognormal cohesion, 4 realisations
    per case): study.nc holds each case's pf, equal to that case's own probabilistic.nc; the same
    realisations (same seed) fail no more often on the stronger soil; pf.png is drawn."""
    text = probabilistic(4) + '\n[sweep]\n[[sweep.axes]]\npath = "materials.soil.friction_deg"\nvalues = [15, 25]\n'
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    ds = xr.load_dataset(tmp_path / "study.nc")
    assert list(ds["friction_deg"].values) == [15, 25]
    for friction in (15, 25):
        case = xr.load_dataset(tmp_path / "cases" / ds["case_folder"].sel(friction_deg=friction).item()
                               / "probabilistic.nc").load()
        assert ds["pf"].sel(friction_deg=friction).item() == pytest.approx(case.attrs["pf"])
        assert case.sizes["realisation"] == 4
    assert ds["pf"].sel(friction_deg=15).item() >= ds["pf"].sel(friction_deg=25).item()
    assert ds["n_failed"].sel(friction_deg=15).item() > 0  # the weak case fails somewhere: the test can tell
    assert outcome.runs_made == 8 and (tmp_path / "pf.png").is_file()


def test_one_worker_and_two_give_the_same_realisations(tmp_path):
    """The same seed on 1 and on 2 workers: the same values, verdicts and pf."""
    text = probabilistic(4)
    one = run_study(parse_study(text), tmp_path / "one", RunOptions(workers=1))
    two = run_study(parse_study(text), tmp_path / "two", RunOptions(workers=2))
    a, b = (xr.load_dataset(tmp_path / name / "probabilistic.nc") for name in ("one", "two"))
    np.testing.assert_array_equal(a["cohesion_pa"].values, b["cohesion_pa"].values)
    assert list(a["verdict"].values) == list(b["verdict"].values)
    assert one.pf == two.pf and one.n_failed > 0
    assert (tmp_path / "one" / "pf_convergence.png").is_file()


def test_a_study_stopped_part_way_resumes_to_the_same_pf(tmp_path):
    """A study stopped after some realisations (here: one realisation's run and probabilistic.nc
    gone, as a kill leaves them) computes only what is missing and gives the same pf."""
    text = probabilistic(4)
    first = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    (tmp_path / "probabilistic.nc").unlink()
    for run_file in (tmp_path / "cases" / "realisation_00002").glob("srf_*.nc"):
        run_file.unlink()
    resumed = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert resumed.runs_made == 1 and resumed.pf == first.pf and resumed.n_failed == first.n_failed


def test_a_target_interval_width_stops_after_the_batch_that_reaches_it(tmp_path, monkeypatch):
    """Batches of 3 (BATCH_REALISATIONS patched): a width of 0.99 is reached after the first batch,
    so 3 of 9 realisations run, and pf is theirs; a width of 0.01 is never reached, so all 9 run,
    reusing the first 3."""
    from workflows.probabilistic import study_type

    monkeypatch.setattr(study_type, "BATCH_REALISATIONS", 3)
    early = run_study(parse_study(probabilistic(9, "pf_interval_width = 0.99")), tmp_path, RunOptions(workers=2))
    assert early.n_realisations == 3 and early.runs_made == 3
    assert xr.load_dataset(tmp_path / "probabilistic.nc").sizes["realisation"] == 3
    full = run_study(parse_study(probabilistic(9, "pf_interval_width = 0.01")), tmp_path, RunOptions(workers=2))
    assert full.n_realisations == 9 and full.runs_made == 6


def _fields_by_run(folder: Path) -> dict[str, bool]:
    """For each run file under ``folder``'s realisations: whether it holds the particle state."""
    found = {}
    for run_file in sorted(folder.glob("cases/*/srf_*.nc")):
        with xr.open_dataset(run_file) as run:
            found[f"{run_file.parent.name}/{run_file.name}"] = "particle_x" in run
    return found


def test_realisations_keep_the_particle_state_the_study_asks_for(tmp_path):
    """fos mode, 4 realisations judged at F = 1.3 (seed 3: realisation 3 fails, 1 and 2 do not), keep_fields_first = 1:
    realisation 0 keeps every run whole; of the others, a failed realisation keeps its failed runs'
    particle state and a stable one none; every run file keeps its histories.  With keep_fields =
    "none" nothing is kept, and the runs are reused; asking for all of them again makes them again."""
    text = probabilistic(4, 'compute = "fos"\nkeep_fields_first = 1')
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    ds = xr.load_dataset(tmp_path / "probabilistic.nc")
    verdicts = dict(zip(ds["case_folder"].values, ds["verdict"].values))
    assert set(list(verdicts.values())[1:]) == {"stable", "failed"}  # both kinds among those without keep_fields_first
    kept = _fields_by_run(tmp_path)
    for name, has_fields in kept.items():
        folder = name.split("/")[0]
        with xr.open_dataset(tmp_path / "cases" / name) as run:
            status = run.attrs["status"]
            assert run.sizes["time"] > 1 and bool(run.attrs["particle_fields"]) == has_fields
        expected = folder.endswith("00000") or (verdicts[folder] == "failed" and status == "failed")
        assert has_fields == expected, name
    none = run_study(parse_study(text.replace("keep_fields_first = 1", 'keep_fields = "none"')), tmp_path / "none",
                     RunOptions(workers=2))
    assert not any(_fields_by_run(tmp_path / "none").values()) and none.pf == outcome.pf
    fos_none = xr.load_dataset(tmp_path / "none" / "probabilistic.nc")["fos"].values
    again = run_study(parse_study(text.replace("keep_fields_first = 1", 'keep_fields = "all"')), tmp_path / "none",
                      RunOptions(workers=2))
    # every run made again, whole, and the same answers (how many runs a search makes beyond those it
    # uses depends on which guesses the workers had time for: not compared)
    assert all(_fields_by_run(tmp_path / "none").values()) and again.pf == none.pf
    np.testing.assert_array_equal(xr.load_dataset(tmp_path / "none" / "probabilistic.nc")["fos"].values, fos_none)


def test_a_worker_killed_mid_study_changes_no_realisation(separate_dask_workers, tmp_path):
    """40 realisations on a separately started scheduler and two workers, one of them killed once
    five realisations are on disk: dask runs the lost task again on the other, and every value,
    verdict and pf equals a clean run on a local cluster (each realisation is its seed's)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    address, workers = separate_dask_workers
    path = tmp_path / "study.toml"
    path.write_text(probabilistic(40))
    process = subprocess.Popen([sys.executable, "-m", "workflows.cli", str(path), "--out", str(tmp_path / "killed"),
                                "--scheduler", address, "--quiet"], cwd=REPO, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while len(list((tmp_path / "killed").glob("cases/*/srf_*.nc"))) < 5:
        assert process.poll() is None and time.monotonic() < deadline, "the study ended before the kill"
        time.sleep(0.05)
    os.killpg(workers[0].pid, signal.SIGKILL)
    assert len(list((tmp_path / "killed").glob("cases/*/srf_*.nc"))) < 40  # killed mid-study
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == 0, stderr
    run_study(parse_study(probabilistic(40)), tmp_path / "clean", RunOptions(workers=2))
    killed, clean = (xr.load_dataset(tmp_path / name / "probabilistic.nc") for name in ("killed", "clean"))
    np.testing.assert_array_equal(killed["cohesion_pa"].values, clean["cohesion_pa"].values)
    assert list(killed["verdict"].values) == list(clean["verdict"].values)
    assert killed.attrs["pf"] == clean.attrs["pf"] and 0 < killed.attrs["n_failed"] < 40


ZERO_COHESION = QUICKSTART.replace("cohesion_pa = 10e3", "cohesion_pa = 0.0")  # a cohesionless sand


@pytest.mark.parametrize("text, field", [
    pytest.param(probabilistic(4).replace('cov = 0.3', 'cov = 0.3\nmean = 0.0').replace("lognormal", "normal"),
                 "probabilistic.variables[0].cov", id="variable-mean-0-given"),
    pytest.param(ZERO_COHESION + '\n[probabilistic]\nrealisations = 4\n' + COHESION.replace("lognormal", "normal"),
                 "probabilistic.variables[0].cov", id="variable-mean-0-from-the-file"),
    pytest.param(ZERO_COHESION + '\n[probabilistic]\nrealisations = 4\n'
                 + COHESION.replace("lognormal", "truncated_normal") + "low = 0.0\nhigh = 1e4\n",
                 "probabilistic.variables[0].cov", id="truncated-normal-mean-0"),
    pytest.param(ZERO_COHESION + '\n[random_field]\n[[random_field.properties]]\nname = "c"\nmaterial = "soil"\n'
                 'property = "cohesion_pa"\ndistribution = "normal"\ncov = 0.3\ntheta_x_m = 4.0\n',
                 "random_field.properties[0].cov", id="field-mean-0"),
    pytest.param(probabilistic(4).replace('cov = 0.3', 'std = 1e-300').replace("lognormal", "normal"),
                 "probabilistic.variables[0].std", id="std-that-changes-no-value"),
])
def test_a_random_value_without_spread_is_refused_naming_the_field(text, field, tmp_path):
    """A COV of a zero mean (a cohesionless sand given a COV of cohesion: the natural way to write
    it) or a std too small to change the mean: the realisations would be copies of one computation,
    counted as independent samples (pf = 1 with an interval from 4 copies of one run); refused with
    one line naming the field, where it divided by zero before."""
    with pytest.raises(StudyError) as error:
        study = parse_study(text)
        run_study(study, tmp_path, RunOptions(workers=1))
    assert error.value.field == field, error.value
    if field.endswith(".cov"):
        assert "give std" in error.value.problem
    assert not any(tmp_path.iterdir())


def test_a_random_variable_that_changes_nothing_computed_is_refused(tmp_path):
    """A variable on a field no computation reads (the animation's frame interval): realisations that
    differ only in it are one computation; refused before anything is written, naming the path."""
    text = probabilistic(4).replace("materials.soil.cohesion_pa", "output.animation_interval_s").replace(
        "cov = 0.3", "cov = 0.3\nmean = 0.5")
    with pytest.raises(StudyError, match="changes nothing the study computes") as error:
        run_study(parse_study(text), tmp_path, RunOptions(workers=1))
    assert error.value.field == "probabilistic.variables[0].path"
    assert not any(tmp_path.iterdir())


class _Stop(Exception):
    """Raised by :class:`_StopAfter` to end a study part way."""


class _StopAfter(Progress):
    def __init__(self, count: int):
        self.count = count

    def tally(self, text):
        self.count -= 1
        if self.count == 0:
            raise _Stop


def test_a_study_of_100000_realisations_makes_only_those_about_to_run(tmp_path):
    """Realisations are made (their study checked, folder and case.toml written) only as the case runner
    has room for them: a study of 100,000 realisations stopped once three have concluded has made only
    those and the few the two workers were about to take (engine.CASES_PER_WORKER each), not 100,000."""
    from workflows.fos.engine import CASES_PER_WORKER

    with pytest.raises(_Stop):
        run_study(parse_study(probabilistic(100_000)), tmp_path, RunOptions(workers=2), progress=_StopAfter(3))
    made = sorted(path.parent.name for path in (tmp_path / "cases").glob("*/case.toml"))
    assert 3 <= len(made) <= 3 + CASES_PER_WORKER * 2
    assert made == [f"realisation_{i:05d}" for i in range(len(made))]  # in order, as Monte Carlo draws them


def test_a_target_interval_width_makes_no_realisation_of_the_batches_it_skips(tmp_path, monkeypatch):
    """pf_interval_width on 100,000 realisations in batches of 3 (patched): the interval is reached after
    the first batch, and only its three realisations were ever made."""
    from workflows.probabilistic import study_type

    monkeypatch.setattr(study_type, "BATCH_REALISATIONS", 3)
    outcome = run_study(parse_study(probabilistic(100_000, "pf_interval_width = 0.99")), tmp_path,
                        RunOptions(workers=2))
    assert outcome.n_realisations == 3 and len(list((tmp_path / "cases").iterdir())) == 3


def test_a_resumed_field_study_in_fos_mode_repeats_itself(tmp_path):
    """The undrained random-field study in fos mode (h = 2 m, 4 realisations): realisation 0 is stable,
    so its failed runs lose their particle state once it concludes (keep_fields = "failed"), yet its
    slip line predicts the windows of realisations 1 and 2.  Run again into the same folder (as after a
    kill), every realisation concludes from its runs on disk: no run is made, every FOS is the same, and
    realisation 0's summary keeps its slip line (read back from the summary the first run wrote)."""
    text = (REPO / "studies" / "probabilistic_undrained.toml").read_text()
    text = (text.replace("spacing_m = 1.0", "spacing_m = 2.0").replace("realisations = 200", "realisations = 4")
            .replace('compute = "verdict"', 'compute = "fos"'))
    run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    first = xr.load_dataset(tmp_path / "probabilistic.nc")
    assert first["verdict"].values[0] == "stable"
    summary = tmp_path / "cases" / "realisation_00000" / "summary.nc"
    assert xr.load_dataset(summary)["slip_x"].size > 1
    (tmp_path / "probabilistic.nc").unlink()
    resumed = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert resumed.runs_made == 0
    np.testing.assert_array_equal(xr.load_dataset(tmp_path / "probabilistic.nc")["fos"].values, first["fos"].values)
    assert xr.load_dataset(summary)["slip_x"].size > 1


def test_a_realisation_handed_out_late_in_its_generation_is_predicted_from_the_earlier_ones(tmp_path, monkeypatch):
    """fos mode: realisation 0 is generation 1, realisations 1 and 2 generation 2.  Realisation 2 handed
    out after realisation 1 concluded is still predicted from realisation 0 alone (the order the
    realisations of a generation conclude in differs between an uninterrupted and a resumed study);
    once the generation is over, both join the prediction."""
    from types import SimpleNamespace

    from workflows.probabilistic import study_type

    monkeypatch.setattr(study_type, "case_result", lambda result: result)
    monkeypatch.setattr(study_type, "realisation_verdict", lambda *args: study_type.STABLE)
    study = study_type.ProbabilisticStudy(parse_study(probabilistic(6, 'compute = "fos"')), tmp_path)
    study.check(RunOptions(workers=2))

    def conclude(case):
        _, windows = study.generation_windows
        estimate = windows.pending[case.case_id][1]  # its FOS: its limit-equilibrium estimate (ratio 1)
        outcome = SimpleNamespace(diverged=False, fos=estimate, runs=[], result=SimpleNamespace(slip="none"))
        study.case_concluded(case.case_id, outcome, Progress())

    [first] = study.cases()
    conclude(first)
    [second] = study.more_cases(1)
    conclude(second)
    [third] = study.more_cases(1)
    _, windows = study.generation_windows
    assert third.case_id.endswith("00002") and len(windows.predictor.ratios) == 1
    conclude(third)
    study.more_cases(1)
    assert len(windows.predictor.ratios) == 3
