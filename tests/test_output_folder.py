"""The output folder is the user's: a study deletes only the run files it made, one study at a time
writes in a folder (a lock, taken over when its process is gone), and --out and --scheduler misuse
is one line and exit 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from workflows.cli import app
from workflows.fos.run_store import remove_stale_runs
from workflows.output.folder_lock import LOCK_NAME, STUDY_NAME_FILE, folder_lock, folder_study, study_digest
from workflows.output.writing import share_file, write_bytes
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = REPO / "studies" / "quickstart.toml"


def netcdf(path: Path, **attrs) -> None:
    ds = xr.Dataset({"max_displacement": ("time", np.zeros(2))})
    ds.attrs.update(attrs)
    ds.to_netcdf(path, engine="netcdf4")


def test_only_run_files_of_another_study_are_removed(tmp_path):
    netcdf(tmp_path / "srf_1.1000.nc", srf=1.1, run_key="another study")
    netcdf(tmp_path / "srf_1.2000.nc", srf=1.2, run_key="mine")
    netcdf(tmp_path / "srf_field_survey.nc", note="the user's")
    (tmp_path / "report.nc.tmp").write_text("the user's")
    (tmp_path / "srf_1.3000.nc.tmp").write_bytes(b"half a run file a killed process left")
    removed = remove_stale_runs(tmp_path, lambda srf: "mine")
    assert removed == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.nc.tmp", "srf_1.2000.nc", "srf_field_survey.nc"]


def test_run_files_that_keep_fewer_particle_fields_than_asked_are_removed(tmp_path):
    """A run made under keep_fields = "none" holds less than a study that keeps every run's fields
    asks: made again if the search asks for it, and never left beside the new runs if it does not."""
    from workflows.fos.task import RunPolicy

    netcdf(tmp_path / "srf_1.1000.nc", srf=1.1, run_key="mine", run_fields="none")
    netcdf(tmp_path / "srf_1.2000.nc", srf=1.2, run_key="mine", run_fields="failed")
    netcdf(tmp_path / "srf_1.3000.nc", srf=1.3, run_key="mine", run_fields="all")
    assert remove_stale_runs(tmp_path, lambda srf: "mine", RunPolicy(fields="failed")) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["srf_1.2000.nc", "srf_1.3000.nc"]
    assert remove_stale_runs(tmp_path, lambda srf: "mine", RunPolicy(fields="all")) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["srf_1.3000.nc"]


def test_a_file_named_as_a_run_file_without_a_run_key_is_refused_not_overwritten(tmp_path):
    netcdf(tmp_path / "srf_1.2000.nc", note="the user's")
    with pytest.raises(StudyError) as error:
        remove_stale_runs(tmp_path, lambda srf: "mine")
    assert error.value.field == "--out" and "was not made by spfem-fos" in str(error.value)
    assert (tmp_path / "srf_1.2000.nc").is_file()


def test_a_folder_in_use_is_refused_and_given_back(tmp_path):
    out = tmp_path / "out"
    with folder_lock(out, "first"):
        holder = json.loads((out / LOCK_NAME).read_text())
        with pytest.raises(StudyError) as error:
            with folder_lock(out, "second"):
                pass
        assert error.value.field == "--out" and "in use by study 'first'" in str(error.value)
        assert json.loads((out / LOCK_NAME).read_text()) == holder  # still the first's
    assert not out.exists()  # made for the lock, nothing written: removed again


def test_a_folder_holding_another_studys_results_is_refused_unless_forced(tmp_path):
    """A different study run into an earlier study's folder removed its runs and realisations as
    stale; it is refused before anything is removed, --force lets it replace them, and the same
    study resumes: changed (the same name), or renamed (the same digest of what it computes), its
    folder marked or known by its result files from before the mark."""
    out = tmp_path / "out"
    with folder_lock(out, "first", digest="d1"):
        (out / "srf_1.1000.nc").write_text("the first study's run")
    assert folder_study(out) == ("first", "d1")
    with pytest.raises(StudyError, match="holds the results of study 'first', and this is study 'second'") as error:
        with folder_lock(out, "second", digest="d2"):
            pass
    assert error.value.field == "--out" and "another --out, or --force" in error.value.problem
    assert (out / "srf_1.1000.nc").is_file() and not (out / LOCK_NAME).exists()
    with folder_lock(out, "first", digest="d3"):  # the same study, changed
        pass
    with folder_lock(out, "renamed", digest="d3"):  # and renamed
        pass
    with folder_lock(out, "second", digest="d2", force=True):
        pass
    assert folder_study(out) == ("second", "d2")
    (out / STUDY_NAME_FILE).unlink()  # a folder from before the mark: known by its result files
    text = QUICKSTART.read_text()
    netcdf(out / "summary.nc", spfem_fos_version="0.1.0", study_name="quickstart", study=text)
    renamed = parse_study(text.replace('name = "quickstart"', 'name = "renamed"'))
    assert folder_study(out) == ("quickstart", study_digest(renamed))
    with folder_lock(out, "renamed", digest=study_digest(renamed)):
        pass
    (out / STUDY_NAME_FILE).unlink()
    with pytest.raises(StudyError, match="holds the results of study 'quickstart'"):
        with folder_lock(out, "other", digest="d4"):
            pass


def test_check_refuses_another_studys_folder_with_the_runs_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out"
    with folder_lock(out, "other"):
        (out / "srf_1.1000.nc").write_text("the other study's run")
    lines = []
    for command in (["check", str(QUICKSTART), "--out", str(out)], [str(QUICKSTART), "--out", str(out), "--quiet"]):
        run = subprocess.run([sys.executable, "-m", "workflows.cli", *command], capture_output=True, text=True,
                             cwd=REPO)
        assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
        lines.append(run.stderr)
    assert lines[0] == lines[1] == (f"error: {QUICKSTART}: --out: {out} holds the results of study 'other', and this "
                                    "is study 'quickstart': its runs would replace them; give another --out, or "
                                    "--force to replace them\n")
    assert sorted(p.name for p in out.iterdir()) == [STUDY_NAME_FILE, "srf_1.1000.nc"]


def test_a_stale_lock_is_taken_over(tmp_path):
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": gone.pid, "host": __import__("socket").gethostname(),
                                                  "study": "killed", "started": "earlier"}))
    said = []
    with folder_lock(tmp_path, "next", said.append):
        assert json.loads((tmp_path / LOCK_NAME).read_text())["study"] == "next"
    assert said and "left by study 'killed'" in said[0] and "no longer runs" in said[0]
    assert not (tmp_path / LOCK_NAME).exists() and tmp_path.is_dir()


@pytest.mark.parametrize("options, line", [
    (["--out", ""], "error: --out: empty"),
    (["--out", "x" * 300], "bytes long, more than file systems allow (255)"),
    (["--scheduler", ""], "error: --scheduler: empty"),
    (["--scheduler", "tcp://127.0.0.1:1", "--workers", "2"], "error: --workers: applies to local workers"),
    (["--scheduler", "tcp://127.0.0.1:1"], "--scheduler: cannot connect to tcp://127.0.0.1:1: Connection refused"),
    (["--scheduler", "tcp://127.0.0.1:port"], "--scheduler: tcp://127.0.0.1:port: not an address"),
])
def test_out_and_scheduler_misuse_is_one_line_and_exit_2(tmp_path, monkeypatch, options, line):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, [str(QUICKSTART), *options])
    assert result.exit_code == 2 and line in result.stderr and result.stderr.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_two_studies_on_one_folder_one_is_refused(tmp_path):
    """A second, different study started on the folder of a running one: exit 2 naming the first,
    and the first finishes as if alone."""
    other = tmp_path / "other.toml"
    other.write_text(QUICKSTART.read_text().replace('name = "quickstart"', 'name = "other"'))
    out = tmp_path / "out"
    first = subprocess.Popen([sys.executable, "-m", "workflows.cli", str(QUICKSTART), "--out", str(out), "--quiet"],
                             cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / LOCK_NAME).exists():
            assert first.poll() is None and time.monotonic() < deadline, "the first study never took the lock"
            time.sleep(0.05)
        second = subprocess.run([sys.executable, "-m", "workflows.cli", str(other), "--out", str(out), "--quiet"],
                                cwd=REPO, capture_output=True, text=True)
        assert second.returncode == 2
        assert "in use by study 'quickstart'" in second.stderr and second.stderr.count("\n") == 1
        stdout, _ = first.communicate(timeout=300)
    finally:
        first.kill()
    assert first.returncode == 0 and stdout.startswith("FOS = ")
    assert not (out / LOCK_NAME).exists()


def test_a_folder_that_fills_up_ends_in_one_line_and_the_rerun_resumes(tmp_path):
    """The study's process may write files of at most 64 KiB (RLIMIT_FSIZE, as a nearly full disk):
    the first larger file fails in one line, exit 2, no half-written file; the same command without
    the limit then finishes with the FOS of an unhindered run, reusing the runs already written."""
    import resource

    out = tmp_path / "out"
    command = [sys.executable, "-m", "workflows.cli", str(QUICKSTART), "--out", str(out), "--quiet"]

    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, resource.RLIM_INFINITY))

    full = subprocess.run(command, cwd=REPO, capture_output=True, text=True, preexec_fn=small_files)
    lines = [line for line in full.stderr.splitlines() if line.strip()]
    assert full.returncode == 2 and len(lines) == 1, full.stderr
    assert "File too large" in lines[0] and "run the same command again to resume" in lines[0]
    assert not list(out.glob("*.tmp")) and not (out / LOCK_NAME).exists()
    rerun = subprocess.run(command, cwd=REPO, capture_output=True, text=True)
    assert rerun.returncode == 0 and rerun.stdout.startswith("FOS = 1.388, bracket [1.383, 1.392]"), rerun.stdout


def test_figures_of_an_earlier_run_are_replaced_and_a_users_picture_stays(tmp_path):
    """A figure of ours that this invocation does not draw again is removed (another FOS bracket, or
    figures = false); a picture of the user's with a figure's name stays."""
    from workflows.cases import RunOptions
    from workflows.output.figures import pyplot, save_figure
    from workflows.study import parse_study
    from workflows.study_types import run_study

    out = tmp_path / "out"
    out.mkdir()
    plt = pyplot()
    fig = plt.figure()
    save_figure(fig, out / "fields_srf_9.9999.png")  # ours, of a run this study does not pick
    fig.savefig(out / "fields_srf_mine.png")  # the user's
    plt.close(fig)
    text = QUICKSTART.read_text()
    run_study(parse_study(text), out, RunOptions(workers=2))
    names = {path.name for path in out.glob("*.png")}
    assert "fields_srf_9.9999.png" not in names and {"fields_srf_mine.png", "srf_curve.png"} <= names
    run_study(parse_study(text + "\n[output]\nfigures = false\n"), out, RunOptions(workers=2))
    assert {path.name for path in out.glob("*.png")} == {"fields_srf_mine.png"}


def test_a_shared_file_is_a_hard_link_or_a_copy_and_never_half_written(tmp_path, monkeypatch):
    """share_file links (one file on disk) or, without hard links, copies; a temporary file a killed
    process left linked to the source is replaced, not written through (which would change the source)."""
    source = tmp_path / "a" / "gravity.nc"
    source.parent.mkdir()
    source.write_bytes(b"gravity state")
    target = tmp_path / "b" / "gravity.nc"
    target.parent.mkdir()
    os.link(source, target.with_name("gravity.nc.tmp"))  # left by a killed process
    write_bytes(b"another state", target)
    assert source.read_bytes() == b"gravity state" and target.read_bytes() == b"another state"
    share_file(source, target)
    assert target.samefile(source) and not list(target.parent.glob("*.tmp"))

    def no_links(*args):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_links)
    copy = tmp_path / "c" / "gravity.nc"
    copy.parent.mkdir()
    share_file(source, copy)
    assert copy.read_bytes() == b"gravity state" and not copy.samefile(source)
