"""Parameter studies: sweep tables and the slope form as the study file gives them, bad sweeps
refused before anything runs, and sweeps end to end (study.nc, shared gravity, identical cases,
a killed sweep resumed on fewer workers, a separately started cluster), with the physics they
must reproduce: FOS proportional to cu for phi = 0, and Taylor's (1937) chart."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from verification import stability_chart
from workflows.cases import RunOptions
from workflows.fos.keys import case_key
from workflows.study import StudyError, parse_study
from workflows.study.reading import sweep_cases
from workflows.study.toml_text import to_toml
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
SWEEP = (REPO / "studies" / "sweep_strength.toml").read_text()
TAYLOR = (REPO / "studies" / "published" / "taylor_phi0.toml").read_text()
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()


def cli(*args):
    return subprocess.run([sys.executable, "-m", "workflows.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=REPO)


def with_sweep(text: str, sweep: str) -> str:
    """``text`` (a study with or without a sweep) with its [sweep] replaced by ``sweep``."""
    head = text.split("[sweep]")[0]
    return head.rstrip() + "\n\n" + sweep


# ------------------------------------------------------------------ the sweep table


def test_grid_cases_in_order_each_with_its_own_study():
    cases = sweep_cases(parse_study(SWEEP))
    assert [c.case_id for c in cases[:4]] == [
        "cohesion_pa=5000__friction_deg=15", "cohesion_pa=5000__friction_deg=20",
        "cohesion_pa=5000__friction_deg=25", "cohesion_pa=10000__friction_deg=15",
    ]
    assert [c.position for c in cases] == [(i, j) for i in range(3) for j in range(3)]
    for case in cases:
        soil = case.study.materials[0]
        assert (soil.cohesion_pa, soil.friction_deg) == (case.values["cohesion_pa"], case.values["friction_deg"])
        assert case.study.sweep is None
        assert parse_study(case.study.source_text) == case.study  # the case text is a study of its own
    assert len({case_key(c.study) for c in cases}) == 9


def test_zip_and_evenly_spaced_axes():
    sweep = ('[sweep]\ncombination = "zip"\n[[sweep.axes]]\npath = "geometry.slope.angle_deg"\n'
             'start = 50.0\nstop = 80.0\ncount = 3\n[[sweep.axes]]\npath = "materials.clay.cohesion_pa"\n'
             'values = [10e3, 20e3, 30e3]\n')
    cases = sweep_cases(parse_study(with_sweep(TAYLOR, sweep)))
    assert [(c.values["angle_deg"], c.values["cohesion_pa"]) for c in cases] == [
        (50.0, 10e3), (65.0, 20e3), (80.0, 30e3)]
    assert [c.position for c in cases] == [(0,), (1,), (2,)]
    assert [c.study.geometry.slope.angle_deg for c in cases] == [50.0, 65.0, 80.0]


BAD_SWEEPS = {
    "unknown field": ('path = "materials.soil.cohesion"\nvalues = [1e3]',
                      "sweep.axes[0].path: materials.soil.cohesion: unknown field (did you mean 'cohesion_pa'?)"),
    "unknown entry": ('path = "materials.sand.cohesion_pa"\nvalues = [1e3]',
                      "sweep.axes[0].path: materials.sand.cohesion_pa: no [[materials]] with name 'sand'"),
    "a table": ('path = "materials.soil"\nvalues = [1e3]', "sweep.axes[0].path: materials.soil: name an entry"),
    "wrong type": ('path = "materials.soil.cohesion_pa"\nvalues = [5e3, "ten"]',
                   "sweep.axes[0].values[1]: materials.soil.cohesion_pa: must be a number"),
    "out of range": ('path = "materials.soil.friction_deg"\nvalues = [20.0, 95.0]',
                     "sweep.axes[0].values[1]: materials.soil.friction_deg: must be < 90"),
    "twice": ('path = "materials.soil.friction_deg"\nvalues = [20.0, 25.0, 20.0]',
              "sweep.axes[0].values[2]: 20.0 appears twice"),
    "half a range": ('path = "materials.soil.friction_deg"\nstart = 10.0\nstop = 20.0', "sweep.axes[0].count: required"),
    "the sweep itself": ('path = "sweep.combination"\nvalues = ["zip"]', "sweep.axes[0].path: sweep: unknown field"),
    "a case as a whole": ('path = "materials.soil.friction_deg"\nvalues = [0.0]\n[[sweep.axes]]\n'
                          'path = "materials.soil.cohesion_pa"\nvalues = [0.0]',
                          "sweep: the case friction_deg=0, cohesion_pa=0: materials[0].cohesion_pa: a material with"),
    "a coarse case": ('path = "geometry.spacing_m"\nvalues = [1.0, 4.0]',
                      "sweep: the case spacing_m=4: geometry.spacing_m: 4 m: the slope height 10 m spans fewer than 4"),
}


@pytest.mark.parametrize("name", BAD_SWEEPS)
def test_a_bad_sweep_is_one_line_exit_2_and_nothing_written(name, tmp_path):
    axis, expected = BAD_SWEEPS[name]
    path = tmp_path / "bad.toml"
    path.write_text(with_sweep(SWEEP, f"[sweep]\n[[sweep.axes]]\n{axis}\n"))
    run = cli(path, "--out", tmp_path / "out")
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith(f"error: {path}: {expected}"), run.stderr
    assert run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert not (tmp_path / "out").exists()


def test_a_case_whose_scene_fails_is_named_before_the_field_and_nothing_is_written(tmp_path):
    """A value that only the scene refuses (a support box left empty) names the case first: the
    field it names is the case's, not the study file's.  The scenes are built before the case folders
    are written (they were built only as each case ran, after every case.toml was written: the
    study-file fuzzer's material region off the domain)."""
    path = tmp_path / "bad.toml"
    path.write_text(with_sweep(SWEEP, '[sweep]\n[[sweep.axes]]\npath = "boundary.base.y_max_m"\nvalues = [-10.0]\n'))
    run = cli(path, "--out", tmp_path / "out")
    assert run.returncode == 2, run.stderr
    assert run.stderr == f"error: {path}: sweep: the case y_max_m=-10: boundary[0]: the box of 'base' holds no particle\n"
    assert not (tmp_path / "out").exists()
    off = SWEEP.replace('name = "soil"', 'name = "soil"\nregion_m = [[1000.0, 0.0], [1060.0, 0.0], [1060.0, 15.0]]', 1)
    assert off != SWEEP
    path.write_text(with_sweep(off, '[sweep]\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [8e3, 12e3]\n'))
    run = cli(path, "--out", tmp_path / "out")
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "lie in no material region" in run.stderr, run.stderr
    assert not (tmp_path / "out").exists()


def test_zip_of_unequal_axes_is_refused_and_a_stage_study_may_be_swept():
    unequal = ('[sweep]\ncombination = "zip"\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [1e3, 2e3]\n'
               '[[sweep.axes]]\npath = "materials.soil.friction_deg"\nvalues = [20.0]\n')
    with pytest.raises(StudyError, match=r"^sweep\.axes: zip needs axes of equal length, got \[2, 1\]"):
        parse_study(with_sweep(SWEEP, unequal))
    column = (REPO / "studies" / "elastic_column.toml").read_text()
    sweep = '[sweep]\n[[sweep.axes]]\npath = "geometry.spacing_m"\nvalues = [0.1, 0.2]\n'
    assert parse_study(column + "\n" + sweep).sweep.axes[0].points == (0.1, 0.2)  # workflows.sweep.study_type


# ------------------------------------------------------------------ the slope form


def slope_study(slope: str, extra: str = "") -> str:
    head = TAYLOR.split("[geometry.slope]")[0]
    tail = TAYLOR.split("[[materials]]", 1)[1].split("[sweep]")[0]
    return f"{head}[geometry.slope]\n{slope}\n{extra}\n[[materials]]{tail}"


def test_slope_form_makes_the_polygon_supports_and_monitors():
    study = parse_study(slope_study("height_m = 10.0\ngradient = 2.0"))  # D = H / 2, crest and toe 2 H
    reference = parse_study(QUICKSTART)  # the same slope, written out
    assert study.geometry.polygon_m == reference.geometry.polygon_m
    # the same supports, except that the form's base lets the soil slide along it at its strength
    base = dataclasses.replace(reference.boundary[0], vx_m_s=None, slip="soil")
    assert study.boundary == (base, *reference.boundary[1:])
    assert [(m.name, m.x_m, m.y_m) for m in study.monitors] == [(m.name, m.x_m, m.y_m) for m in reference.monitors]
    steep = parse_study(slope_study("height_m = 4.0\nangle_deg = 60.0\nfoundation_depth_m = 0.0\ncrest_length_m = 6.0"))
    run = 4.0 / math.tan(math.radians(60.0))
    np.testing.assert_allclose(steep.geometry.polygon_m, [(0, 0), (6 + run, 0), (6, 4), (0, 4)], atol=1e-12)
    assert [b.name for b in steep.boundary] == ["base", "left"]  # no roller on the free face
    vertical = parse_study(slope_study("height_m = 5.0\nangle_deg = 90.0\nfoundation_depth_m = 0.0"))
    assert vertical.geometry.polygon_m == ((0.0, 0.0), (10.0, 0.0), (10.0, 5.0), (0.0, 5.0))


def test_slope_form_layers_take_the_materials_from_the_top():
    two = TAYLOR.split("[[materials]]", 1)[1].split("[loads]")[0]
    layered = slope_study("height_m = 10.0\ngradient = 2.0\nlayer_depths_m = [6.0]").replace(
        "[[materials]]" + two, "[[materials]]" + two + "[[materials]]" + two.replace('"clay"', '"stiff"'))
    study = parse_study(layered)
    upper, lower = (np.array(m.region_m) for m in study.materials)
    assert upper[:, 1].min() == pytest.approx(9.0) and lower[:, 1].max() == pytest.approx(9.0)  # 15 - 6


@pytest.mark.parametrize("slope, expected", [
    ("height_m = 10.0", "geometry.slope.angle_deg: give angle_deg or gradient"),
    ("height_m = 10.0\nangle_deg = 30.0\ngradient = 2.0", "geometry.slope.angle_deg: give angle_deg or gradient"),
    ("height_m = 10.0\nangle_deg = 30.0\nlayer_depths_m = [4.0, 2.0]", "geometry.slope.layer_depths_m: must increase"),
    ("height_m = 10.0\nangle_deg = 30.0\nlayer_depths_m = [4.0]", "geometry.slope.layer_depths_m: makes 2 layers, for 1"),
    ("height_m = -1.0\nangle_deg = 30.0", "geometry.slope.height_m: must be > 0"),
])
def test_slope_form_errors_name_the_field(slope, expected):
    with pytest.raises(StudyError) as error:
        parse_study(slope_study(slope))
    assert str(error.value).startswith(expected), str(error.value)
    both = slope_study("height_m = 10.0\nangle_deg = 30.0").replace("[geometry.slope]",
                                                                      "polygon_m = [[0, 0], [1, 0], [1, 1]]\n[geometry.slope]")
    with pytest.raises(StudyError, match="^geometry.polygon_m: give polygon_m or"):
        parse_study(both)


@pytest.mark.parametrize("name", ["quickstart", "sweep_strength", "sweep_geometry", "published/taylor_phi0",
                                  "published/acads_1c", "collapse_granular"])
def test_toml_text_reads_back_as_the_same_study(name):
    text = (REPO / "studies" / f"{name}.toml").read_text()
    assert parse_study(to_toml(tomllib.loads(text))) == parse_study(text)


# ------------------------------------------------------------------ sweeps end to end


def test_study_nc_holds_every_case_over_the_sweep_dimensions(strength_sweep):
    study, out, outcome = strength_sweep
    ds = xr.load_dataset(out / "study.nc")
    assert ds["fos"].dims == ("cohesion_pa", "friction_deg")
    assert ds["cohesion_pa"].attrs["units"] == "Pa" and ds["friction_deg"].attrs["units"] == "degree"
    assert ds["cohesion_pa"].attrs["sweep_path"] == "materials.soil.cohesion_pa"
    np.testing.assert_array_equal(ds["cohesion_pa"], [5e3, 10e3, 15e3])
    assert ds.attrs["study"] == study.source_text and ds.attrs["n_cases"] == 9
    for case in outcome.cases:
        at = dict(cohesion_pa=case.values["cohesion_pa"], friction_deg=case.values["friction_deg"])
        folder = out / "cases" / str(ds["case_folder"].sel(at).values)
        summary = xr.load_dataset(folder / "summary.nc")
        assert float(ds["fos"].sel(at)) == float(summary["fos"])  # the case's own answer
        assert float(ds["fos_low"].sel(at)) == summary["fos"].attrs["fos_low"]
        assert (folder / "case.toml").read_text() == case.study.source_text
    assert (ds["status"] == "found").all()
    # stronger soil, safer slope: along both axes
    assert (ds["fos"].diff("cohesion_pa") > 0).all() and (ds["fos"].diff("friction_deg") > 0).all()
    assert outcome.gravity_computed == 1  # an elastic gravity stage does not see the strength
    assert [p.name for p in outcome.figures] == ["fos_cohesion_pa.png", "fos_friction_deg.png", "fos_map.png"]


def test_cases_that_compute_the_same_thing_are_computed_once(tmp_path):
    quick = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 2.0").replace("figures = true", "figures = false")
    study = parse_study(quick + '\n[sweep]\n[[sweep.axes]]\npath = "study.description"\nvalues = ["a", "b"]\n')
    outcome = run_study(study, tmp_path, RunOptions(workers=1))
    assert outcome.n_distinct == 1
    ds = xr.load_dataset(tmp_path / "study.nc")
    assert list(ds["case_folder"].values) == ["description=a", "description=a"]
    assert ds["fos"][0] == ds["fos"][1] and not (tmp_path / "cases" / "description=b").exists()


def test_a_changed_value_recomputes_only_its_case(tmp_path):
    quick = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 2.0").replace("figures = true", "figures = false")
    axis = '\n[sweep]\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [{}]\n'
    first = run_study(parse_study(quick + axis.format("8e3, 10e3")), tmp_path, RunOptions(workers=1))
    assert first.runs_reused == 0 and first.gravity_computed == 1
    gravity = tmp_path / "cases" / "cohesion_pa=8000" / "gravity.nc"
    assert gravity.samefile(tmp_path / "cases" / "cohesion_pa=10000" / "gravity.nc")  # one file on disk
    kept = {p: p.stat().st_mtime_ns for p in (tmp_path / "cases" / "cohesion_pa=8000").glob("srf_*.nc")}
    second = run_study(parse_study(quick + axis.format("8e3, 12e3")), tmp_path, RunOptions(workers=1))
    assert second.runs_reused == first.results["cohesion_pa=8000"].n_runs
    assert second.runs_made == second.results["cohesion_pa=12000"].n_runs
    assert second.gravity_computed == 0  # the new case takes the gravity files of the case it shares them with
    assert (tmp_path / "cases" / "cohesion_pa=12000" / "gravity.nc").samefile(gravity)
    assert all(p.stat().st_mtime_ns == t for p, t in kept.items())
    assert second.results["cohesion_pa=8000"] == first.results["cohesion_pa=8000"]


def test_a_changed_sweep_removes_what_the_earlier_one_made_and_nothing_of_the_users(tmp_path):
    """Rerun with one axis fewer, then with figures = false: the case folders and design charts
    of the earlier invocations go, each time said in one line; a picture, a file and a folder of the
    user's stay (a stale case folder holding a file of the user's is kept, emptied of ours)."""
    from workflows.output.figures import pyplot
    from workflows.study_types import study_type

    quick = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 2.0")
    cohesion = '[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [8e3, 10e3]\n'
    friction = '[[sweep.axes]]\npath = "materials.soil.friction_deg"\nvalues = [15.0, 20.0]\n'

    def run(text: str) -> list[str]:
        kind = study_type(parse_study(text), tmp_path)
        outcome = run_study(kind.study, tmp_path, RunOptions(workers=1), kind=kind)
        return [line for line in kind.report(outcome, False, None).lines if line.startswith(("removed", "kept"))]

    assert run(quick + "\n[sweep]\n" + cohesion + friction) == []
    assert {p.name for p in tmp_path.glob("*.png")} == {"fos_cohesion_pa.png", "fos_friction_deg.png", "fos_map.png"}
    plt = pyplot()
    fig = plt.figure()
    fig.savefig(tmp_path / "fos_mine.png")  # the user's, named as a design chart
    plt.close(fig)
    (tmp_path / "cases" / "cohesion_pa=8000__friction_deg=15" / "notes.txt").write_text("mine")
    (tmp_path / "cases" / "mine").mkdir()
    (tmp_path / "cases" / "mine" / "summary.nc").write_bytes(b"not a netCDF file")

    [line] = run(quick + "\n[sweep]\n" + cohesion)
    assert line.startswith("removed what an earlier invocation made: 3 case folders no longer in the sweep"), line
    assert "figures not drawn again (fos_friction_deg.png, fos_map.png)" in line
    assert line.endswith("kept cases/cohesion_pa=8000__friction_deg=15/: no longer in the sweep, but holding files "
                         "not known as made by spfem-fos"), line
    assert {p.name for p in (tmp_path / "cases").iterdir()} == {"cohesion_pa=8000", "cohesion_pa=10000",
                                                                "cohesion_pa=8000__friction_deg=15", "mine"}
    assert [p.name for p in (tmp_path / "cases" / "cohesion_pa=8000__friction_deg=15").iterdir()] == ["notes.txt"]
    assert (tmp_path / "cases" / "mine" / "summary.nc").is_file()
    assert {p.name for p in tmp_path.glob("*.png")} == {"fos_cohesion_pa.png", "fos_mine.png"}

    [line] = run(quick + "\n[output]\nfigures = false\n\n[sweep]\n" + cohesion)
    assert line.startswith("removed what an earlier invocation made: figures not drawn again (fos_cohesion_pa.png)")
    assert {p.name for p in tmp_path.glob("*.png")} == {"fos_mine.png"}
    assert (tmp_path / "study.nc").is_file()


def test_fos_is_proportional_to_cu_for_phi_0(tmp_path):
    """phi = 0, fixed geometry: F = cu / (N gamma H), so F / cu is one number (verification.stability_chart)."""
    ratios = stability_chart.fos_per_cu(tmp_path, workers=2)
    assert list(ratios) == list(stability_chart.CU_VALUES_PA)
    assert max(ratios.values()) / min(ratios.values()) - 1.0 < stability_chart.CU_BAND, ratios


@pytest.mark.slow
def test_taylor_chart_for_phi_0_within_3_percent(tmp_path):
    """studies/published/taylor_phi0.toml: the toe-circle branch of Taylor's chart, 4 values."""
    points = stability_chart.taylor_points(tmp_path, workers=2)
    assert len(points) == 4
    assert all(abs(p.error) < stability_chart.TAYLOR_BAND for p in points), points


def test_killed_sweep_resumes_on_one_worker_with_the_same_study_nc(strength_sweep, tmp_path):
    """Killed once three cases are done, rerun on one worker: finished runs are reused, not
    rewritten, and study.nc holds the numbers of the uninterrupted run on two workers."""
    _, first_out, _ = strength_sweep
    path, out = tmp_path / "sweep.toml", tmp_path / "out"
    path.write_text(SWEEP)
    log = tmp_path / "first.log"
    with log.open("w") as sink:
        process = subprocess.Popen([sys.executable, "-m", "workflows.cli", str(path), "--out", str(out)],
                                   stdout=sink, stderr=subprocess.STDOUT, cwd=REPO, start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        while len(list(out.glob("cases/*/summary.nc"))) < 3:
            assert process.poll() is None, log.read_text()
            assert time.monotonic() < deadline, "no case finished in time"
            time.sleep(0.05)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    assert not (out / "study.nc").exists()
    finished = {p: p.stat().st_mtime_ns for p in out.glob("cases/*/srf_*.nc")}
    concluded = {p.parent.name for p in out.glob("cases/*/summary.nc")}
    rerun = cli(path, "--out", out, "--workers", "1")
    assert rerun.returncode == 0, rerun.stderr
    assert "reused" in rerun.stdout.splitlines()[0]
    first, again = xr.load_dataset(first_out / "study.nc"), xr.load_dataset(out / "study.nc")
    assert again.drop_attrs().identical(first.drop_attrs())
    used = 0
    for case_folder in again["case_folder"].values.flat:
        summary = xr.load_dataset(out / "cases" / case_folder / "summary.nc")
        for srf in summary["srf"].values:
            run = out / "cases" / case_folder / f"srf_{srf:.4f}.nc"
            if run in finished:
                assert run.stat().st_mtime_ns == finished[run]  # reused, not recomputed
                used += 1
            else:  # the cases concluded before the kill made no run again
                assert case_folder not in concluded, run
    assert len(concluded) >= 3 and used >= len(concluded) * 3
    assert "cohesion_pa  friction_deg" in rerun.stdout


def test_sweep_on_a_separately_started_dask_cluster(strength_sweep, separate_dask_scheduler_file, tmp_path):
    """The shipped sweep through the scheduler file of a separately started scheduler and two workers
    (docs/cluster.md's recipe; tests/test_scale_out.py kills a worker of such a job, in the slow suite)."""
    _, local_out, _ = strength_sweep
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP)
    run = cli(path, "--out", tmp_path / "out", "--scheduler", separate_dask_scheduler_file, "--quiet")
    assert run.returncode == 0, run.stderr
    local, remote = xr.load_dataset(local_out / "study.nc"), xr.load_dataset(tmp_path / "out" / "study.nc")
    assert remote.drop_attrs().identical(local.drop_attrs())
    assert run.stdout.splitlines()[0].split() == ["cohesion_pa", "friction_deg", "FOS", "bracket", "runs", "status"]


# ------------------------------------------------------------------ a sweep of a runout study

RUNOUT_SWEEP = (REPO / "studies" / "runout_residual_friction_sweep.toml").read_text()


def test_a_runout_study_swept_over_residual_friction(tmp_path):
    """The shipped runout sweep cut to two cases and 6 s: each case's stages run in its folder,
    study.nc holds the runout metrics over (residual_friction_deg, runout_stage) equal to the
    cases' stage files, the lower residual friction runs further, and a second invocation reads
    everything back without running a step."""
    path = tmp_path / "sweep.toml"
    path.write_text(RUNOUT_SWEEP.replace("values = [8.0, 10.0, 12.0]", "values = [8.0, 12.0]")
                    .replace('kind = "runout"\nmax_duration_s = 20.0', 'kind = "runout"\nmax_duration_s = 6.0'))
    out = tmp_path / "out"
    first = cli(path, "--out", out)
    assert first.returncode == 0, first.stderr
    assert "2 cases, 2 run, 0 up to date" in first.stdout
    with xr.open_dataset(out / "study.nc") as ds:
        assert dict(ds["runout_m"].sizes) == {"residual_friction_deg": 2, "runout_stage": 1}
        assert list(ds["status"].values) == ["done", "done"]
        runout = ds["runout_m"].values[:, 0]
        for i, folder in enumerate(ds["case_folder"].values):
            with xr.open_dataset(out / "cases" / folder / "softening.nc") as case:
                for name in ("runout_m", "retrogression_m", "sliding_mass_area_m2", "energy_budget_error"):
                    assert float(case[name]) == float(ds[name].values[i, 0])
                assert float(ds["n_particles"].values[i]) == case.sizes["particle"]
        stored = ds.load()
    assert runout[0] > runout[1] > 0.0  # 8 deg runs further than 12
    assert (out / "runout_residual_friction_deg.png").is_file()
    second = cli(path, "--out", out)
    assert second.returncode == 0, second.stderr
    assert "2 cases, 0 run, 2 up to date" in second.stdout
    with xr.open_dataset(out / "study.nc") as again:
        assert np.array_equal(again["runout_m"].values, stored["runout_m"].values)
