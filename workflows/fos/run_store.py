"""The run files of a strength-reduction study on disk: names, reuse, writing, stale files.

Each finished SRF run is written by the study's process to ``OUT/srf_<F>.nc`` (temporary
name, then rename), as its worker made it: with its key (``workflows.fos.keys``) and its
record as ``run_<name>`` attributes.  A rerun reuses a file with the same key, removes run files
another study made (named ``srf_<F>.nc`` and carrying another ``run_key``), and recomputes a
damaged one.  Nothing else in the folder is touched: a file named as a run file but without a
``run_key`` is the user's, and the study refuses to write over it.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import xarray as xr

from workflows.fields import StudyError
from workflows.fos.task import (
    FIELDS_POLICY_ATTRIBUTE,
    PARTICLE_FIELDS_ATTRIBUTE,
    RESULT_SCALARS,
    RunPolicy,
    RunRecord,
    SrfRunResult,
)
from workflows.output.writing import interrupts_deferred, write_bytes, write_dataset

SUMMARY_NAME = "summary.nc"


def run_file_name(srf: float) -> str:
    return f"srf_{srf:.4f}.nc"


RUN_FILE_NAME = re.compile(r"srf_[0-9]+\.[0-9]{4}\.nc")
"""The names :func:`run_file_name` gives: the only files :func:`remove_stale_runs` looks at."""


def stored_run(path: Path, key: str, policy: RunPolicy = RunPolicy()) -> RunRecord | None:
    """The record of a finished run file with this key (made by an earlier invocation: no start and
    end in this one); None if missing, stale, damaged (a damaged file is removed), or made under a
    policy that keeps fewer particle fields than ``policy`` (then it is made again)."""
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
    if not policy.covered_by(attrs.get(FIELDS_POLICY_ATTRIBUTE, "all")):
        return None
    return RunRecord(srf=float(attrs["srf"]), n_particles=int(attrs.get("n_particles", 0)),
                     **{name: attrs[f"run_{name}"] for name in RESULT_SCALARS})


def write_run(result: SrfRunResult, path: Path) -> None:
    """Put a run's file (made on its worker, keys included) on disk."""
    write_bytes(result.file_bytes, path)


def remove_stale_runs(out_dir: Path, key_of: Callable[[float], str], policy: RunPolicy = RunPolicy()) -> int:
    """Delete run files that another study made (another slope, strength or core): a file named as
    a run file (:data:`RUN_FILE_NAME`) whose ``run_key`` is not ``key_of(its srf)``, a damaged one,
    one made under a policy that keeps fewer particle fields than ``policy`` (the search makes it
    again if it asks for that value; if not, it must not stay beside this study's runs as if it held
    what they hold), and the temporary files of run files a killed process left.  StudyError on ``--out`` for a file
    named as a run file that is readable but carries no ``run_key``: not ours, and a run would
    write over it."""
    removed = 0
    for path in sorted(out_dir.glob("srf_*.nc")):
        if not RUN_FILE_NAME.fullmatch(path.name):
            continue
        try:
            with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
                attrs = dict(ds.attrs)
        except (OSError, ValueError, RuntimeError):
            attrs = None  # damaged (ours are written whole, then renamed): made again
        if attrs is not None and "run_key" not in attrs:
            raise StudyError("--out", f"{path} was not made by spfem-fos (no run_key attribute) and a run of this "
                             "study writes that name; move it or choose another output folder")
        if (attrs is None or "srf" not in attrs or attrs["run_key"] != key_of(float(attrs["srf"]))
                or not policy.covered_by(attrs.get(FIELDS_POLICY_ATTRIBUTE, "all"))):
            path.unlink(missing_ok=True)
            removed += 1
    for path in out_dir.glob("srf_*.nc.tmp"):
        if RUN_FILE_NAME.fullmatch(path.name[: -len(".tmp")]):
            path.unlink(missing_ok=True)
    return removed


def without_particle_fields(path: Path) -> bool:
    """Rewrite the run file ``path`` without its final particle state (the ``particle`` and ``face``
    variables and the mesh), keeping its histories, verdict and keys; False if it had none."""
    with interrupts_deferred(), xr.open_dataset(path, engine="netcdf4") as ds:
        if not ds.attrs.get(PARTICLE_FIELDS_ATTRIBUTE, 1):
            return False
        dropped = [name for name, variable in ds.variables.items()
                   if {"particle", "face"} & set(variable.dims) or name == "mesh2d"]
        slim = ds.drop_vars(dropped).load()
    slim.attrs[PARTICLE_FIELDS_ATTRIBUTE] = 0
    write_dataset(slim, path)
    return True
