"""``study.nc`` of a sweep: every case's FOS (or, for a stage study, its metrics) over the sweep's dimensions.

Variables and attributes as declared in :data:`workflows.output.variables.SWEEP_FILE`,
``STAGE_SWEEP_FILE``, ``SWEEP_AXIS_ATTRIBUTES`` and ``SWEEP_FILE_ATTRIBUTES``.  A grid has one dimension per axis
(named by its label, the axis values as coordinate); a zip has the dimension ``case``, each
axis a coordinate over it.  The file holds only what does not depend on the number of workers
or on what an earlier invocation left, so a resumed sweep writes the same numbers.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass

import numpy as np
import xarray as xr

from workflows.fos.verdict import DIVERGED, FAILED, STABLE
from workflows.output.stage_file import provenance
from workflows.output.variables import COLLAPSE_METRICS, RUNOUT_METRICS, STAGE_SWEEP_FILE, SWEEP_FILE
from workflows.study import Study
from workflows.study.reading import SweepCase, axis_labels, resolve_sweep_path

STUDY_FILE_NAME = "study.nc"
CASES_FOLDER = "cases"
CASE_TEXT_NAME = "case.toml"
"""Where a sweep (of a FOS study or a stage study) puts its file, its cases' folders and each case's text."""

FOUND, ABOVE, BELOW, NO_KNEE, GRAVITY_DIVERGED = "found", "above_srf_max", "below_srf_min", "no_knee", "gravity_diverged"


def _scalar_names(table) -> list[str]:
    return [name for name, variable in table.items() if variable.dims == ()]


DONE, DIVERGED_CASE = "done", "diverged"
"""Statuses of a stage study's case."""

RUNOUT_SCALARS = _scalar_names(RUNOUT_METRICS)
"""The runout metrics ``study.nc`` of a stage study's sweep holds per runout stage."""
COLLAPSE_SCALARS = _scalar_names(COLLAPSE_METRICS)
"""The collapse metrics ``study.nc`` of a stage study's sweep holds (with ``[metrics]``)."""


@dataclass(frozen=True)
class CaseResult:
    """What ``study.nc`` and the final table hold of one case."""

    fos: float
    fos_low: float
    fos_high: float
    status: str  # FOUND, ABOVE, BELOW, NO_KNEE or GRAVITY_DIVERGED
    criteria_agree: bool
    knee_srf: float
    n_particles: int
    n_runs: int  # runs the case's answer rests on (reused or made)
    verdict: str  # the case's one-line verdict


def case_result(outcome) -> CaseResult:
    """The result of a concluded case from its ``FosOutcome``; with no FOS, the bound the runs give:
    above_srf_max (fos_low = the highest stable SRF), below_srf_min (fos_high = the lowest failed), or
    no_knee (the run verdicts' bracket: the highest stable SRF below the lowest failed one)."""
    runs = [r for r in outcome.runs if r.status != DIVERGED]
    fos, low, high = outcome.fos, outcome.fos_low, outcome.fos_high
    if math.isfinite(fos):
        status = FOUND
    elif runs and all(r.status == STABLE for r in runs):
        status, low = ABOVE, max(r.srf for r in runs)
    elif runs and all(r.status == FAILED for r in runs):
        status, high = BELOW, min(r.srf for r in runs)
    else:
        status, low, high = NO_KNEE, outcome.status_low, outcome.status_high
    return CaseResult(fos, low, high, status, bool(outcome.criteria_agree), outcome.knee_srf, outcome.n_particles,
                      len(outcome.runs), outcome.verdict)


def diverged_result(error: str, n_particles: int) -> CaseResult:
    """The result of a case whose gravity stage diverged."""
    nan = math.nan
    return CaseResult(nan, nan, nan, GRAVITY_DIVERGED, False, nan, n_particles, 0, error)


def _coordinate(values: list):
    """Axis values as a coordinate: numbers as floats (integers kept), anything else as text."""
    if all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=float)
    return np.array([v if isinstance(v, str) else str(list(v) if isinstance(v, tuple) else v) for v in values],
                    dtype=object)


def sweep_coordinates(study: Study, cases: list[SweepCase]) -> tuple[tuple[str, ...], tuple[int, ...], dict]:
    """(dims, shape, coordinates) of a sweep's ``study.nc``: a grid has a dimension per axis
    (the axis values as coordinate), a zip the dimension ``case`` with each axis over it."""
    sweep = study.sweep
    labels = axis_labels(sweep)
    specs = [resolve_sweep_path(tomllib.loads(study.source_text), axis.path)[2] for axis in sweep.axes]
    dims: tuple[str, ...]
    shape: tuple[int, ...]
    if sweep.combination == "zip":
        dims = ("case",)
        shape = (len(cases),)
    else:
        dims = tuple(labels)
        shape = tuple(len(axis.points) for axis in sweep.axes)
    coords = {}
    for a, (label, axis, spec) in enumerate(zip(labels, sweep.axes, specs)):
        if sweep.combination == "zip":
            values = [case.values[label] for case in cases]
        else:
            values = [None] * shape[a]
            for case in cases:
                values[case.position[a]] = case.values[label]
        coords[label] = (dims[0] if sweep.combination == "zip" else label, _coordinate(values),
                         {"units": spec.unit or "1", "long_name": spec.doc, "sweep_path": axis.path})
    if sweep.combination == "zip":
        coords["case"] = ("case", np.arange(len(cases)), {"units": "1", "long_name": "case number"})
    return dims, shape, coords


def study_dataset(study: Study, cases: list[SweepCase], results: dict[str, CaseResult], folders: dict[str, str],
                  n_distinct: int) -> xr.Dataset:
    """``study.nc`` of ``study`` from the ``results`` of its ``cases`` and the folder that holds
    each one's files (its own, or that of an identical case), both by case id."""
    sweep = study.sweep
    dims, shape, coords = sweep_coordinates(study, cases)

    def grid(dtype, fill):
        return np.full(shape, fill, dtype=dtype)

    columns = {"case_folder": grid(object, ""), "fos": grid(float, np.nan), "fos_low": grid(float, np.nan),
               "fos_high": grid(float, np.nan), "status": grid(object, ""), "criteria_agree": grid(np.int8, 0),
               "knee_srf": grid(float, np.nan), "n_particles": grid(np.int64, 0)}
    for case in cases:
        result = results[case.case_id]
        at = case.position
        columns["case_folder"][at] = folders[case.case_id]
        for name in ("fos", "fos_low", "fos_high", "status", "knee_srf", "n_particles"):
            columns[name][at] = getattr(result, name)
        columns["criteria_agree"][at] = int(result.criteria_agree)
    ds = xr.Dataset(coords=coords)
    for name, values in columns.items():
        ds[name] = SWEEP_FILE[name].over(dims, values)
    ds.attrs = {
        "title": f"spfem-fos parameter study {study.name}: FOS of every case",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "sweep_combination": sweep.combination,
        "sweep_axes": ", ".join(axis.path for axis in sweep.axes),
        "n_cases": len(cases),
        "n_cases_distinct": int(n_distinct),
        **provenance(study),
    }
    return ds


@dataclass
class StageCaseResult:
    """What ``study.nc`` and the printed table hold of one case."""

    status: str  # DONE or DIVERGED_CASE
    message: str  # the divergence, or ""
    n_particles: int
    runout: dict[str, dict[str, float]]  # runout stage name -> scalar metric -> value
    collapse: dict[str, float]  # scalar collapse metric -> value (empty without [metrics])
    ran: bool  # False: its results were up to date and were read back


def runout_stage_names(study: Study) -> list[str]:
    """Names of the study's runout stages, in stage order."""
    return [stage.name for stage in study.stages if stage.follows_runout]


def stage_sweep_dataset(study: Study, cases: list[SweepCase], results: dict[str, StageCaseResult]) -> xr.Dataset:
    """``study.nc`` of a stage study's sweep (module doc; variables ``STAGE_SWEEP_FILE``,
    ``RUNOUT_METRICS``, ``COLLAPSE_METRICS``)."""
    dims, shape, coords = sweep_coordinates(study, cases)
    stages = runout_stage_names(study)
    columns = {"case_folder": np.full(shape, "", dtype=object), "status": np.full(shape, "", dtype=object),
               "status_reason": np.full(shape, "", dtype=object), "n_particles": np.zeros(shape, dtype=np.int64)}
    runout = {key: np.full((*shape, len(stages)), np.nan) for key in RUNOUT_SCALARS}
    collapse = {key: np.full(shape, np.nan) for key in COLLAPSE_SCALARS}
    for case in cases:
        result, at = results[case.case_id], case.position
        columns["case_folder"][at] = case.case_id
        columns["status"][at] = result.status
        columns["status_reason"][at] = result.message
        columns["n_particles"][at] = result.n_particles
        for s, stage in enumerate(stages):
            for key, value in result.runout.get(stage, {}).items():
                runout[key][(*at, s)] = value
        for key, value in result.collapse.items():
            collapse[key][at] = value
    ds = xr.Dataset(coords=coords)
    for name, values in columns.items():
        ds[name] = STAGE_SWEEP_FILE[name].over(dims, values)
    if stages:
        ds = ds.assign_coords(runout_stage=("runout_stage", np.array(stages, dtype=object),
                                            {"units": "1", "long_name": "name of the runout stage"}))
        for key, values in runout.items():
            ds[key] = RUNOUT_METRICS[key].over((*dims, "runout_stage"), values)
    if study.metrics is not None:
        for key, values in collapse.items():
            ds[key] = COLLAPSE_METRICS[key].over(dims, values)
    sweep = study.sweep
    ds.attrs = {
        "title": f"spfem-fos parameter study {study.name}: the metrics of every case",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "sweep_combination": sweep.combination,
        "sweep_axes": ", ".join(axis.path for axis in sweep.axes),
        "n_cases": len(cases),
        **provenance(study),
    }
    return ds
