"""The result files are described once: every variable a file holds is declared, with the
declared units and long name, and the generated reference page is up to date."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import xarray as xr

from workflows.output import reference
from workflows.output.variables import COLLAPSE_METRICS, GRADED_CLOUD_VARIABLES, STAGE_FILE, SUMMARY_FILE

REPO = Path(__file__).resolve().parents[1]


def _matches_declarations(ds: xr.Dataset, declared: dict) -> None:
    for name, variable in ds.variables.items():
        assert name in declared, f"{name} is not declared in workflows/output/variables.py"
        assert variable.attrs["units"] == declared[name].units, name
        assert variable.attrs["long_name"] == declared[name].long_name, name
        assert tuple(variable.dims) == declared[name].dims, name


def test_quickstart_files_hold_exactly_what_is_declared(quickstart_run):
    _, out, _ = quickstart_run
    with xr.open_dataset(out / "summary.nc") as summary:
        _matches_declarations(summary, SUMMARY_FILE)
        assert set(summary.variables) == set(SUMMARY_FILE)
    with xr.open_dataset(out / "gravity.nc") as gravity:
        _matches_declarations(gravity, STAGE_FILE)
        assert set(gravity.variables) == set(STAGE_FILE) - set(GRADED_CLOUD_VARIABLES)  # a uniform cloud


def test_result_file_reference_in_docs_is_up_to_date():
    output = subprocess.run([sys.executable, "-m", "workflows.output.reference"], capture_output=True, text=True,
                            check=True, cwd=REPO).stdout
    assert output == reference.page()
    page = (REPO / "docs" / "result-files.md").read_text(encoding="utf-8")
    assert page == reference.page(), f"docs/result-files.md is stale: run {reference.REGENERATE}"
    for name in (*STAGE_FILE, *COLLAPSE_METRICS, *SUMMARY_FILE):
        assert f"`{name}`" in page, name
