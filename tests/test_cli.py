"""The spfem-fos command: bad input exits 2 with one line and writes nothing; a tiny beam
study runs end to end into a complete run.nc."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr
from typer.testing import CliRunner

from spfem_core import simulation
from spfem_core.divergence import DivergenceError
from workflows.cli import app
from workflows.materials import MATERIAL_MODELS

REPO = Path(__file__).resolve().parents[1]
BEAM = (REPO / "studies" / "cantilever_beam.toml").read_text()

def write_study(folder: Path, text: str, name: str = "study.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def invoke(*args: str):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_bad_study_exits_2_with_one_line_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = write_study(tmp_path, BEAM.replace("spacing_m = 0.02", "spacing_m = -0.1"))
    for args in ([study], [study, "--out", tmp_path / "out"]):
        result = invoke(*args)
        assert result.exit_code == 2
        assert result.stderr == f"error: {study}: geometry.spacing_m: must be > 0, got -0.1\n"
        assert result.stdout == ""
        assert sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


def test_toml_syntax_error_exits_2(tmp_path):
    study = write_study(tmp_path, BEAM.replace("spacing_m = 0.02", "spacing_m 0.02"))
    result = invoke(study, "--out", tmp_path / "out")
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {study}: line ") and result.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_missing_file_exits_2_with_one_line(tmp_path):
    result = invoke(tmp_path / "nowhere.toml", "--out", tmp_path / "out")
    assert result.exit_code == 2
    assert result.stderr == f"error: {tmp_path / 'nowhere.toml'}: no such file\n"
    assert list(tmp_path.iterdir()) == []


def test_python_dash_m_entry_point(tmp_path):
    study = write_study(tmp_path, BEAM.replace('model = "elastic"', 'model = "plastic"'))
    run = subprocess.run(
        [sys.executable, "-m", "workflows.cli", str(study), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    models = ", ".join(f'"{name}"' for name in MATERIAL_MODELS)
    assert run.returncode == 2
    assert run.stderr == f'error: {study}: materials[0].model: must be one of {models}, got "plastic"\n'
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("args, line", [
    ([], "error: Missing argument 'STUDY.toml'. (spfem-fos --help)"),
    (["study.toml", "--bogus"], "error: No such option: --bogus"),
])
def test_usage_errors_are_one_line_and_exit_2(args, line):
    run = subprocess.run([sys.executable, "-m", "workflows.cli", *args], capture_output=True, text=True, cwd=REPO)
    assert run.returncode == 2 and run.stderr.startswith(line) and run.stderr.count("\n") == 1, run.stderr


def test_help_names_check_and_version_prints_the_version_the_files_carry():
    from spfem_core import __version__

    run = subprocess.run([sys.executable, "-m", "workflows.cli", "--help"], capture_output=True, text=True, cwd=REPO,
                         env={**os.environ, "COLUMNS": "200"})
    assert run.returncode == 0 and "spfem-fos check STUDY.toml" in run.stdout and "--version" in run.stdout
    run = subprocess.run([sys.executable, "-m", "workflows.cli", "--version"], capture_output=True, text=True, cwd=REPO)
    assert (run.returncode, run.stdout, run.stderr) == (0, f"spfem-fos {__version__}\n", "")


# ---------------------------------------------------------------------------------------
# With the core
# ---------------------------------------------------------------------------------------

TINY_BEAM = (
    BEAM.replace('name = "cantilever_beam"', 'name = "tiny_beam"')
    .replace("spacing_m = 0.02", "spacing_m = 0.05")
    .replace("duration_s = 4.0", "duration_s = 0.05")
    .replace("record_interval_s = 0.001", "record_interval_s = 0.005")
)
REQUIRED_VARIABLES = [
    "time", "monitor", "monitor_ux", "monitor_uy", "monitor_vx", "monitor_vy",
    "monitor_sxx", "monitor_syy", "monitor_szz", "monitor_sxy", "kinetic_energy", "max_displacement",
    "particle_x", "particle_y", "particle_ux", "particle_uy", "mesh2d", "mesh2d_face_nodes",
]  # fmt: skip
REQUIRED_ATTRIBUTES = [
    "n_particles", "n_steps", "n_remesh", "wall_time_s", "dt_s", "study", "spfem_fos_version", "created_utc",
]  # fmt: skip


def test_tiny_beam_end_to_end(tmp_path):
    study = write_study(tmp_path, TINY_BEAM)
    out = tmp_path / "beam"
    result = invoke(study, "--out", out)
    assert result.exit_code == 0, result.output
    assert f"wrote {out / 'run.nc'}" in result.stdout
    assert sorted(p.name for p in out.iterdir()) == [".spfem-fos.study", "report.html", "run.nc"]  # no figure
    with xr.open_dataset(out / "run.nc") as ds:
        for name in REQUIRED_VARIABLES:
            assert name in ds.variables, name
        for name, variable in ds.variables.items():
            assert variable.attrs.get("units") is not None and variable.attrs.get("long_name"), name
        for name in REQUIRED_ATTRIBUTES:
            assert name in ds.attrs, name
        assert ds.attrs["study"] == TINY_BEAM
        assert list(ds.monitor.values) == ["tip"]
        assert ds.monitor_uy.dims == ("monitor", "time") and ds.monitor_uy.attrs["units"] == "m"
        assert ds.time.values[-1] == pytest.approx(0.05, abs=0.006)
        assert float(ds.monitor_uy.sel(monitor="tip").isel(time=-1)) < 0.0  # the tip falls under gravity
        assert ds.attrs["n_steps"] > 0 and ds.attrs["n_particles"] == ds.sizes["particle"]

    again = invoke(study, "--out", out)
    assert again.exit_code == 0 and "up to date" in again.stdout

    quiet = invoke(study, "--out", out, "--force", "--quiet")  # the one-line result and nothing else
    assert quiet.exit_code == 0 and quiet.stderr == ""
    assert quiet.stdout.count("\n") == 1 and quiet.stdout.startswith("tiny_beam: ") and "particles" in quiet.stdout


def test_boundary_box_without_particles_exits_2(tmp_path):
    study = write_study(tmp_path, TINY_BEAM.replace("x_max_m = 0.0", "x_min_m = 5.0"))
    result = invoke(study, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {study}: boundary[0]: ") and result.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_divergence_exits_1_without_result(tmp_path, monkeypatch):
    def diverge(self, *args, **kwargs):
        raise DivergenceError("velocity is not finite", step=7, time_s=0.0007)

    monkeypatch.setattr(simulation.Simulation, "run", diverge)
    study = write_study(tmp_path, TINY_BEAM)
    result = invoke(study, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 1
    assert "step 7" in result.stderr and "0.0007" in result.stderr and result.stderr.count("\n") == 1
    assert not (tmp_path / "out" / "run.nc").exists()


def test_a_closed_worker_connection_is_one_line_not_an_abort(tmp_path, monkeypatch):
    """click turns an EOFError into Abort (exit 1, "Aborted!", or 130 as Ctrl-C): the study never
    reads stdin, so an EOFError is a pipe to another process that closed; one line, exit 2."""
    def closed(self, *args, **kwargs):
        raise EOFError("Ran out of input")

    monkeypatch.setattr(simulation.Simulation, "run", closed)
    study = write_study(tmp_path, TINY_BEAM)
    result = invoke(study, "--out", tmp_path / "out", "--quiet")
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert "connection closed unexpectedly (EOFError: Ran out of input)" in result.stderr
    assert "run the same command again to resume" in result.stderr and "Aborted" not in result.output


SLOPE = (REPO / "studies" / "quickstart.toml").read_text()


@pytest.mark.parametrize("case", ["utf-16", "binary", "out is a file", "out cannot be made", "spacing 1e-300",
                                  "spacing 1 mm on the slope", "max-memory too small", "jitter 0.4",
                                  "study is a folder"])
def test_inputs_that_used_to_crash_exit_2_with_one_line(case, tmp_path):
    """Each of these ended in a traceback (or the kernel killing the process for its memory)."""
    study = tmp_path / "study.toml"
    study.write_text(SLOPE)
    out = tmp_path / "out"
    options = []
    if case == "utf-16":
        study.write_bytes(SLOPE.encode("utf-16"))
        expected = "not a UTF-8 text file"
    elif case == "binary":
        study.write_bytes(bytes(range(256)))
        expected = "not a UTF-8 text file"
    elif case == "out is a file":
        out.write_text("")
        expected = "--out: "
    elif case == "out cannot be made":
        out = Path("/proc/spfem-fos-cannot-make-this")
        expected = "--out: cannot make the output folder"
    elif case == "spacing 1e-300":
        study.write_text(SLOPE.replace("spacing_m = 1.0", "spacing_m = 1e-300"))
        expected = "geometry.spacing_m: 1e-300 m gives more particles than can be counted"
    elif case == "spacing 1 mm on the slope":  # about 9e8 particles
        study.write_text(SLOPE.replace("spacing_m = 1.0", "spacing_m = 0.001"))
        expected = "geometry.spacing_m: 0.001 m gives about"
    elif case == "max-memory too small":
        options = ["--max-memory", "0.001"]
        expected = "allowed by --max-memory"
    elif case == "jitter 0.4":
        study.write_text(SLOPE.replace("spacing_m = 1.0", "spacing_m = 1.0\njitter = 0.4"))
        expected = "geometry.jitter: must be < 0.3"
    else:
        study = tmp_path / "folder.toml"
        study.mkdir()
        expected = "is a folder"
    result = invoke(study, "--out", out, *options)
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1, result.stderr
    assert expected in result.stderr, result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert not out.is_dir()  # nothing written


def test_quiet_still_prints_warnings_on_stderr(capfd):
    """--quiet keeps stdout to the result; a warning (a thin layer, water over dry ground) still
    reaches stderr, the other messages do not (the quiet console used to swallow both).  Messages
    wait for the work to start: a study refused when its scene is built prints its error alone."""
    from rich.console import Console

    from workflows.cli import BarsProgress

    warning = "warning: water.phreatic_level_m: the water stands 3 m above the ground surface"
    for completed in (True, False):
        progress = BarsProgress(Console(stderr=True, quiet=True), quiet=True, sweep=False)
        progress.message("gravity state reused from gravity.nc")
        progress.message(warning)
        assert capfd.readouterr() == ("", "")
        progress.stop(completed=completed)
        assert capfd.readouterr() == ("", warning + "\n" if completed else "")
    progress = BarsProgress(Console(stderr=True, quiet=True), quiet=True, sweep=False)
    progress.message(warning)
    progress.stage("", "gravity", "relaxation", 0.5)  # the work starts: held messages go out
    assert capfd.readouterr().err == warning + "\n"
    progress.stop()
