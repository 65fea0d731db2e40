"""The run files of a strength-reduction study on disk: names, reuse, writing, stale files.

Each finished SRF run is written by the study's process to ``OUT/srf_<F>.nc`` (temporary
name, then rename) with its key (``workflows.fos.keys``) and its scalars as ``run_<name>``
attributes.  A rerun reuses a file with the same key, removes files of another gravity state,
and recomputes a damaged one.
"""

from __future__ import annotations

import math
from pathlib import Path

import xarray as xr

from workflows.fos.task import SrfRunResult
from workflows.output.writing import interrupts_deferred, write_dataset

SUMMARY_NAME = "summary.nc"


def run_file_name(srf: float) -> str:
    return f"srf_{srf:.4f}.nc"



RESULT_SCALARS = ("status", "status_reason", "max_displacement_m", "final_kinetic_energy_j_per_m", "stop_time_s",
                   "wall_time_s", "remesh_wall_s", "n_steps")


def stored_run(path: Path, key: str) -> dict | None:
    """The scalars of a finished run file with this key; None if missing, stale or damaged."""
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
    # made by an earlier invocation: no start and end in this one
    return {name: attrs[f"run_{name}"] for name in RESULT_SCALARS} | {
        "srf": float(attrs["srf"]), "started_s": math.nan, "finished_s": math.nan,
    }


def run_scalars(result: SrfRunResult, study_start_unix_s: float) -> dict:
    """The scalars of a run made now, with its start and end on the worker in s since the study started."""
    return {name: getattr(result, name) for name in RESULT_SCALARS} | {
        "srf": result.srf,
        "started_s": result.started_unix_s - study_start_unix_s,
        "finished_s": result.finished_unix_s - study_start_unix_s,
    }


def write_run(result: SrfRunResult, path: Path, key: str, gkey: str) -> None:
    ds = result.dataset
    ds.attrs.update({f"run_{name}": getattr(result, name) for name in RESULT_SCALARS})
    ds.attrs.update(run_key=key, gravity_key=gkey)
    write_dataset(ds, path)


def remove_stale_runs(out_dir: Path, gkey: str) -> int:
    """Delete run files of another gravity state (another slope or another core)."""
    removed = 0
    for path in out_dir.glob("srf_*.nc"):
        try:
            with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
                stale = ds.attrs.get("gravity_key") != gkey
        except (OSError, ValueError, RuntimeError):
            stale = True
        if stale:
            path.unlink(missing_ok=True)
            removed += 1
    for path in out_dir.glob("*.nc.tmp"):
        path.unlink(missing_ok=True)
    return removed


