"""The conclusion of one strength-reduction case: its FOS from its runs, ``summary.nc`` and the figures.

``summary.nc`` holds a row per SRF run and the factor of safety: variables and attributes as
declared in :data:`workflows.output.variables.SUMMARY_FILE`, ``FOS_ATTRIBUTES`` and
``SUMMARY_FILE_ATTRIBUTES`` (coordinate ``srf``; scalar ``fos``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.fos.criterion import brackets_agree, curvature, first_failed_sweep_srf, status_bracket
from workflows.fos.domain_edges import EdgeContact, edge_contacts
from workflows.fos.figures import FIGURE_NAMES, draw_figures
from workflows.fos.report import verdict_line
from workflows.fos.run_store import SUMMARY_NAME, run_file_name
from workflows.fos.slip_surface import SlipSurface, run_particles, slip_surface
from workflows.fos.task import RunRecord
from workflows.fos.verdict import DIVERGED, displacement_floor_m
from workflows.output.figures import remove_stale_figures
from workflows.output.stage_file import provenance
from workflows.output.variables import SUMMARY_FILE
from workflows.output.writing import write_dataset
from workflows.scene import build_material_table


@dataclass
class FosOutcome:
    """What a strength-reduction study (or one case of a sweep) did and found."""

    out_dir: Path
    summary_path: Path | None  # None: not written (conclude_case)
    fos: float
    fos_low: float
    fos_high: float
    criterion: str
    knee_srf: float  # SRF of maximum curvature of the sweep (NaN: no knee)
    status_low: float
    status_high: float
    criteria_agree: bool
    non_monotone: list[float]  # stable SRF values above a failed one (verdicts not monotone in F)
    verdict: str  # one line for the report
    runs: list[RunRecord] = field(default_factory=list)  # by SRF
    skipped: dict[float, str] = field(default_factory=dict)
    gravity_reused: bool = False
    timings_s: dict[str, float] = field(default_factory=dict)
    n_particles: int = 0
    guesses: tuple[int, int] = (0, 0)  # runs started ahead of the search on idle workers, and used
    figures: list[Path] = field(default_factory=list)
    stiffness_factor: float = 1.0  # the runs' moduli over the declared ones (StrengthReductionStage.stiffness_factor)
    slip: SlipSurface | str = "not extracted"  # the slip surface, or why there is none (slip_surface.py)
    edges: list[EdgeContact] = field(default_factory=list)  # the supports its mechanism reaches (domain_edges.py)


def conclude_case(case, progress, wall_start: float, figures: bool, summary_file: bool = True) -> FosOutcome:
    """The FOS and its report from a case's runs (``case`` a ``workflows.fos.case_search.CaseSearch`` whose
    search is done): its messages, ``summary.nc`` (unless ``summary_file`` is False: a case of one run,
    whose run file holds all of it) and, with ``figures``, the figures."""
    study, out_dir, search, runs = case.study, case.out_dir, case.search, case.runs
    if case.reused_runs:
        progress.message(case.say(f"{case.reused_runs} SRF runs reused from {out_dir} "
                                  "(finished by an earlier invocation)"))
    if case.n_guessed:
        progress.message(case.say(
            f"{case.n_guessed} runs started ahead of the search on idle workers, {case.n_guesses_used} of them "
            "used (the others were stopped or left out of the answer)"
        ))
    by_reason: dict[str, list[float]] = {}
    for srf, reason in sorted(search.skipped.items()):
        if srf not in runs:
            by_reason.setdefault(reason, []).append(srf)
    for reason, values in by_reason.items():
        progress.message(case.say(f"SRF {', '.join(f'{f:g}' for f in values)} not run: {reason}"))

    stage = study.strength_reduction
    floor_m = displacement_floor_m(study)
    ordered = [runs[f] for f in sorted(runs)]
    timings = {"gravity": case.gravity_wall_s, "srf_runs_elapsed": time.perf_counter() - case.started_s,
               "io": case.io_s, "srf_runs_worker": float(sum(r.wall_time_s for r in ordered)),
               "remeshing": float(sum(r.remesh_wall_s for r in ordered))}
    knee = search.knee()
    status = status_bracket([r.srf for r in ordered], [r.status for r in ordered])
    agree = brackets_agree(knee, status, stage.fos_tolerance)
    outcome = FosOutcome(
        out_dir=out_dir, summary_path=out_dir / SUMMARY_NAME, fos=knee.fos, fos_low=knee.fos_low,
        fos_high=knee.fos_high, criterion=knee.reason, knee_srf=knee.knee_srf, status_low=status.fos_low,
        status_high=status.fos_high, criteria_agree=agree, non_monotone=list(status.non_monotone),
        verdict=verdict_line(knee, status, agree, ordered, stage, search.stop_reason), runs=ordered,
        skipped={f: r for f, r in search.skipped.items() if f not in runs}, gravity_reused=case.gravity_reused,
        timings_s=timings, n_particles=case.n_particles, guesses=(case.n_guessed, case.n_guesses_used),
        stiffness_factor=stage.stiffness_factor(build_material_table(study), study),
    )
    if not summary_file:
        outcome.summary_path = None
        (out_dir / SUMMARY_NAME).unlink(missing_ok=True)  # not one of an earlier invocation's
        return outcome
    io_start = time.perf_counter()
    outcome.slip, outcome.edges = case_mechanism(study, out_dir, status)
    if isinstance(outcome.slip, str) and _reused(runs, status.fos_high):  # its particle state removed since
        outcome.slip = earlier_slip_surface(outcome.summary_path, status.fos_high) or outcome.slip
    for contact in outcome.edges if case.label else []:  # a single study's report says it
        if contact.warning:
            progress.message(case.say(f"warning: the box decides: {contact.line}"))
    summary = summary_dataset(study, outcome, knee, status, search.stop_reason, floor_m)
    timings["total"] = time.perf_counter() - wall_start
    summary.attrs.update({f"time_{name}_s": value for name, value in timings.items()})
    write_dataset(summary, outcome.summary_path)
    timings["io"] += time.perf_counter() - io_start
    if figures:
        outcome.figures = draw_figures(out_dir, summary, case.flow)
    # an earlier invocation's figures of other runs (or all of them, figures = false) are not this one's
    remove_stale_figures(out_dir, FIGURE_NAMES, keep={path.name for path in outcome.figures})
    return outcome


def case_mechanism(study, out_dir: Path, status) -> tuple[SlipSurface | str, list[EdgeContact]]:
    """The slip surface of the case's first failed run beyond its last stable run (the status
    bracket), from their run files, or why there is none; and the supports its mechanism reaches."""
    if math.isnan(status.fos_high):
        return "no run failed", []
    failed = run_particles(out_dir / run_file_name(status.fos_high), study)
    if failed is None:
        return f"the run at SRF {status.fos_high:g} kept no particle fields", []
    stable = None
    if not math.isnan(status.fos_low):
        stable = run_particles(out_dir / run_file_name(status.fos_low), study)
    slip = slip_surface(study, failed, stable, status.fos_high, status.fos_low if stable is not None else math.nan)
    return slip, edge_contacts(study, failed, stable, (slip.x_m, slip.y_m) if isinstance(slip, SlipSurface) else None)


def _reused(runs: dict, srf: float) -> bool:
    """Whether the run at ``srf`` is an earlier invocation's (its start time NaN)."""
    record = runs.get(srf)
    return record is not None and record.started_s != record.started_s


def earlier_slip_surface(summary_path: Path, srf: float) -> SlipSurface | None:
    """The slip surface from the failed run at ``srf`` that an earlier invocation wrote to the case's
    ``summary.nc`` (None: no file, or no line from that run).  A resumed case whose runs are all reused
    keeps its slip line though that run's particle state was removed after the first conclusion
    (a probabilistic study's ``keep_fields``): a probabilistic study predicts its later realisations'
    windows from these lines, so a resumed study repeats the uninterrupted one.  The supports the
    mechanism reaches are not kept (they need the particles)."""
    from workflows.fos.limit_equilibrium import SpencerResult

    try:
        with xr.open_dataset(summary_path, engine="netcdf4") as ds:
            if "slip_x" not in ds or ds["slip_x"].size < 2 or float(ds["slip_srf"].values) != srf:
                return None
            slip_srf, le = ds["slip_srf"], ds["le_fos"]
            return SlipSurface(
                x_m=np.asarray(ds["slip_x"].values, dtype=float), y_m=np.asarray(ds["slip_y"].values, dtype=float),
                depth_m=float(ds["slip_depth"].values), area_m2=float(ds["slip_area"].values), srf=srf,
                stable_srf=float(slip_srf.attrs.get("stable_srf", math.nan)),
                moved_m=float(slip_srf.attrs.get("moved_m", math.nan)),
                limit_equilibrium=SpencerResult(float(le.values),
                                                math.radians(float(le.attrs.get("interslice_angle_deg", math.nan))),
                                                str(le.attrs.get("reason", ""))))
    except (OSError, ValueError, KeyError):
        return None


def _slip_variables(ds: xr.Dataset, slip: SlipSurface | str) -> None:
    """The slip surface's variables of ``summary.nc`` (NaN and the reason when there is none)."""
    var = SUMMARY_FILE
    if isinstance(slip, str):
        for name in ("slip_srf", "slip_entry_x", "slip_entry_y", "slip_exit_x", "slip_exit_y", "slip_depth",
                     "slip_area"):
            ds[name] = var[name](math.nan)
        ds["slip_x"], ds["slip_y"] = var["slip_x"](np.array([])), var["slip_y"](np.array([]))
        ds["slip_srf"].attrs["reason"] = slip
        ds["le_fos"] = var["le_fos"](math.nan, reason=f"no slip line: {slip}")
        return
    ds["slip_x"], ds["slip_y"] = var["slip_x"](slip.x_m), var["slip_y"](slip.y_m)
    ds["slip_srf"] = var["slip_srf"](slip.srf, stable_srf=slip.stable_srf, moved_m=slip.moved_m)
    for name, value in (("slip_entry_x", slip.entry_m[0]), ("slip_entry_y", slip.entry_m[1]),
                        ("slip_exit_x", slip.exit_m[0]), ("slip_exit_y", slip.exit_m[1]),
                        ("slip_depth", slip.depth_m), ("slip_area", slip.area_m2)):
        ds[name] = var[name](float(value))
    le = slip.limit_equilibrium
    ds["le_fos"] = var["le_fos"](le.fos, method="Spencer", interslice_angle_deg=float(np.degrees(le.theta_rad)),
                                 reason=le.reason)


def summary_dataset(study, outcome: FosOutcome, knee, status, stop_reason: str, floor_m: float) -> xr.Dataset:
    """The summary of a finished strength-reduction study (``knee`` the ``criterion.FosPick`` and
    ``status`` the ``criterion.StatusBracket`` of its runs)."""
    var = SUMMARY_FILE
    runs = outcome.runs
    srf = np.array([r.srf for r in runs], dtype=float)
    u = np.array([r.max_displacement_m for r in runs], dtype=float)
    stage = study.strength_reduction
    ceiling = first_failed_sweep_srf(srf, [r.status for r in runs], stage.srf_min, stage.srf_step)
    # the curvature of the runs the search decided with: not of runs that finished only by timing
    usable = np.array([r.status != DIVERGED for r in runs], dtype=bool) & (srf <= ceiling)
    kappa = np.full(srf.size, np.nan)
    if usable.sum() >= 3:
        kappa[usable] = curvature(srf[usable], u[usable], floor_m)
    ds = xr.Dataset(coords={"srf": var["srf"](srf)})

    def column(name, key, dtype=float):
        ds[name] = var[name](np.array([getattr(r, key) for r in runs], dtype=dtype))

    ds["max_displacement"] = var["max_displacement"](u)
    column("final_kinetic_energy", "final_kinetic_energy_j_per_m")
    column("status", "status", object)
    column("status_reason", "status_reason", object)
    column("stop_time", "stop_time_s")
    column("wall_time", "wall_time_s")
    column("run_start", "started_s")
    column("run_end", "finished_s")
    column("n_steps", "n_steps", np.int64)
    ds["curvature"] = var["curvature"](kappa)
    ds["fos"] = var["fos"](
        float(knee.fos),
        fos_low=float(knee.fos_low),
        fos_high=float(knee.fos_high),
        knee_srf=float(knee.knee_srf),
        criterion="maximum curvature, convex upturns only: " + knee.reason,
        second_criterion="run verdicts (failed: a mechanism moved past failure_displacement_m, or no "
        "equilibrium at the end): "
        + status.reason,
        status_fos_low=float(status.fos_low),
        status_fos_high=float(status.fos_high),
        criteria_agree=int(bool(outcome.criteria_agree)),
        verdict=outcome.verdict,
    )
    _slip_variables(ds, outcome.slip)
    skipped = sorted(outcome.skipped.items())
    ds.attrs = {
        "title": f"spfem-fos strength-reduction summary of study {study.name}",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "n_particles": int(outcome.n_particles),
        "fos_tolerance": float(stage.fos_tolerance),
        "srf_stiffness_factor": float(outcome.stiffness_factor),
        "displacement_floor_m": float(floor_m),
        "search_stop": stop_reason,
        "srf_not_run": ", ".join(f"{f:g}" for f, _ in skipped),
        "srf_not_run_reason": "; ".join(f"{f:g}: {why}" for f, why in skipped),
        "gravity_reused": int(bool(outcome.gravity_reused)),
        "runs_started_ahead": int(outcome.guesses[0]),
        "runs_started_ahead_used": int(outcome.guesses[1]),
        "box_decides": int(any(contact.warning for contact in outcome.edges)),
        "mechanism_edges": "; ".join(contact.line for contact in outcome.edges),
        **provenance(study),
    }
    return ds
