"""``probabilistic.nc``: every realisation and the statistics of the study, as declared in
``workflows.output.variables.PROBABILISTIC_FILE`` and ``PROBABILISTIC_FILE_ATTRIBUTES``."""

from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import stats

from workflows.distributions import LOGNORMAL, NORMAL
from workflows.fos.slip_surface import envelope
from workflows.output.stage_file import provenance
from workflows.output.variables import PROBABILISTIC_FILE
from workflows.probabilistic.reliability import reliability_index
from workflows.study.reading import _loads, resolve_sweep_path

FAILED, UNDECIDED = "failed", "undecided"


def probabilistic_dataset(study, cases, results: dict, verdicts: list[str], outcome, runs: dict,
                          slip_lines: list | None = None) -> xr.Dataset:
    """The dataset of a finished probabilistic study (``outcome``: its ``ProbabilisticOutcome``; ``runs``:
    each realisation's ``RunRecord`` list by case id, empty where its gravity diverged; ``slip_lines``:
    the failed realisations' slip lines (x, y), whose envelope it holds)."""
    var = PROBABILISTIC_FILE
    table = study.probabilistic
    n = len(cases)
    labels = list(cases[0].values)
    ds = xr.Dataset(coords={"realisation": ("realisation", np.arange(n, dtype=np.int64),
                                            {"long_name": "realisation number"})})
    raw = _loads(study.source_text)
    for label, variable in zip(labels, table.variables):
        spec = resolve_sweep_path(raw, variable.path)[2]
        ds[label] = ("realisation", np.array([case.values[label] for case in cases]),
                     {"units": spec.unit or "1", "long_name": spec.doc, "sweep_path": variable.path,
                      "distribution": variable.distribution})
    column = [results[case.case_id] for case in cases]
    ds["verdict"] = var["verdict"](np.array(verdicts, dtype=object))
    ds["status"] = var["status"](np.array([r.status for r in column], dtype=object))
    for name in ("fos", "fos_low", "fos_high"):
        ds[name] = var[name](np.array([getattr(r, name) for r in column], dtype=float))
    ds["case_folder"] = var["case_folder"](np.array([case.case_id for case in cases], dtype=object))
    records = [runs[case.case_id] for case in cases]
    ds["max_displacement"] = var["max_displacement"](np.array(
        [max((r.max_displacement_m for r in each), default=np.nan) if not table.computation.searches else np.nan
         for each in records]))
    ds["n_runs"] = var["n_runs"](np.array([len(each) for each in records], dtype=np.int64))
    ds["n_steps"] = var["n_steps"](np.array([sum(r.n_steps for r in each) for each in records], dtype=np.int64))
    ds["run_wall_time"] = var["run_wall_time"](np.array([sum(r.wall_time_s for r in each) for each in records]))
    kept = [case.position[0] < table.keep_fields_first or table.keep_fields == "all"
            or (table.keep_fields == "failed" and verdict == FAILED) for case, verdict in zip(cases, verdicts)]
    ds["particle_fields"] = var["particle_fields"](np.array(kept, dtype=np.int8))
    failed = np.cumsum([v == FAILED for v in verdicts])
    decided = np.cumsum([v != UNDECIDED for v in verdicts])
    with np.errstate(invalid="ignore", divide="ignore"):
        ds["pf_running"] = var["pf_running"](np.where(decided > 0, failed / np.maximum(decided, 1), np.nan))
    fos = ds["fos"].values
    found = np.isfinite(fos)
    attrs = {}
    if table.computation.searches and found.sum() >= 3:
        ds = ds.assign_coords(random_variable=("random_variable", np.array(labels, dtype=object),
                                               {"long_name": "random variable"}))
        ranks = [float(stats.spearmanr(ds[label].values[found], fos[found]).statistic) for label in labels]
        ds["fos_rank_correlation"] = var["fos_rank_correlation"](np.array(ranks))
        attrs = {"reliability_index_normal": reliability_index(fos[found], NORMAL),
                 "reliability_index_lognormal": reliability_index(fos[found], LOGNORMAL)}
    if slip_lines:
        x, lower, upper, count = envelope(slip_lines)
        ds["slip_envelope_x"] = var["slip_envelope_x"](x, n_lines=len(slip_lines))
        ds["slip_envelope_lower"] = var["slip_envelope_lower"](lower)
        ds["slip_envelope_upper"] = var["slip_envelope_upper"](upper)
        ds["slip_envelope_count"] = var["slip_envelope_count"](count.astype(np.int64))
    ds.attrs = {
        "title": f"spfem-fos probabilistic study {study.name}",
        "Conventions": "CF-1.11",
        "study_name": study.name,
        "pf": outcome.pf, "pf_low": outcome.pf_low, "pf_high": outcome.pf_high,
        "n_realisations": n, "n_failed": outcome.n_failed, "n_undecided": outcome.n_undecided,
        "method": table.method, "seed": table.seed, "compute": table.compute, "factor": table.factor,
        "fos_mean": outcome.fos_mean, "fos_std": outcome.fos_std,
        "n_mechanisms": outcome.n_mechanisms,
        "mechanism_edges": "; ".join(f"{fraction:.4f} reach {where}" for where, fraction, _ in outcome.edge_fractions),
        "box_decides_fraction": max([fraction for _, fraction, warning in outcome.edge_fractions if warning],
                                    default=0.0),
        **attrs,
        **provenance(study),
    }
    return ds
