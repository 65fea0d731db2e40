"""The run files of a strength-reduction study on disk: names, reuse, writing, stale files.

Each finished SRF run is written by the study's process to ``OUT/srf_<F>.nc`` (temporary
name, then rename), as its worker made it: with its key (``workflows.fos.keys``) and its
record as ``run_<name>`` attributes.  A rerun reuses a file with the same key, removes files
another study made, and recomputes a damaged one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import xarray as xr

from workflows.fos.task import RESULT_SCALARS, RunRecord, SrfRunResult
from workflows.output.writing import interrupts_deferred, write_bytes

SUMMARY_NAME = "summary.nc"


def run_file_name(srf: float) -> str:
    return f"srf_{srf:.4f}.nc"


def stored_run(path: Path, key: str) -> RunRecord | None:
    """The record of a finished run file with this key (made by an earlier invocation: no start and
    end in this one); None if missing, stale or damaged (a damaged file is removed)."""
    if not path.is_file():
        return None
    try:
        with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
            attrs = dict(ds.attrs)
            _ = ds["max_displacement"].values  # a damaged file fails here
    except (OSError, KeyError, ValueError, RuntimeError):
        path.unlink(missing_ok=True)  # damaged: recompute
        return None
    if attrs.get("run_key") != key:
        return None
    return RunRecord(srf=float(attrs["srf"]), **{name: attrs[f"run_{name}"] for name in RESULT_SCALARS})


def write_run(result: SrfRunResult, path: Path) -> None:
    """Put a run's file (made on its worker, keys included) on disk."""
    write_bytes(result.file_bytes, path)


def remove_stale_runs(out_dir: Path, key_of: Callable[[float], str]) -> int:
    """Delete run files that another study made (another slope, strength or core): a file whose
    ``run_key`` is not ``key_of(its srf)``, and leftover temporary files."""
    removed = 0
    for path in out_dir.glob("srf_*.nc"):
        try:
            with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
                stale = ds.attrs.get("run_key") != key_of(float(ds.attrs["srf"]))
        except (OSError, ValueError, RuntimeError, KeyError):
            stale = True
        if stale:
            path.unlink(missing_ok=True)
            removed += 1
    for path in out_dir.glob("*.nc.tmp"):
        path.unlink(missing_ok=True)
    return removed
