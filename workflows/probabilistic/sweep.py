"""A sweep of probabilistic studies: a study with ``[sweep]`` and ``[probabilistic]`` (pf against a
COV, a scale of fluctuation, a mean).

It is the sweep of ``workflows.sweep.nested`` over ``ProbabilisticStudy``:

1. Each case of the sweep (``workflows.study.reading.sweep_cases``) is a probabilistic study of its
   own (``workflows.probabilistic.study_type.ProbabilisticStudy``) in ``OUT/cases/<case>/``: its
   study text ``case.toml`` (a probabilistic study that runs alone and reuses the sweep's
   realisations), its realisations under ``cases/``, its ``probabilistic.nc``.
2. The realisations of every case are tasks on one cluster, all in one round (each made as the
   case runner has room for it, case after case), or with ``pf_interval_width`` in each case's
   batches (realisations of random strengths share one gravity state across the cases too).
3. :class:`ProbabilisticSweep` writes ``OUT/study.nc`` (``workflows.output.variables.PROBABILISTIC_SWEEP_FILE``:
   pf with its interval per case) and ``pf.png`` (pf against the first axis) last.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.cases import CaseTimings, Report
from workflows.output.stage_file import provenance
from workflows.output.variables import PROBABILISTIC_SWEEP_FILE
from workflows.output.writing import write_dataset
from workflows.probabilistic.study_type import ProbabilisticOutcome
from workflows.study.reading import SweepCase
from workflows.sweep.nested import SweepSummary
from workflows.sweep.report import fixed_width_table, value_text
from workflows.sweep.results import CASES_FOLDER, STUDY_FILE_NAME, sweep_coordinates


@dataclass
class ProbabilisticSweepOutcome:
    """What a sweep of probabilistic studies did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    outcomes: dict[str, ProbabilisticOutcome]  # by sweep case id
    runs_made: int
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class ProbabilisticSweep(SweepSummary):
    """What a sweep of probabilistic studies writes and prints (module doc, step 3)."""

    label = "a sweep of probabilistic studies"

    def conclude(self, sweep, concluded: dict, own: dict, timings: CaseTimings,
                 wall_start: float) -> ProbabilisticSweepOutcome:
        """``study.nc`` with pf and its interval per case, and ``pf.png``."""
        results = {case_id: outcome.result for case_id, outcome in concluded.items()}  # (a probabilistic study
        # keeps going past a diverged realisation: never Diverged)
        dims, shape, coords = sweep_coordinates(sweep.study, sweep.sweep_cases)
        columns = {name: np.full(shape, np.nan) for name in ("pf", "pf_low", "pf_high", "fos_mean", "fos_std")}
        columns |= {"n_failed": np.zeros(shape, np.int64), "n_decided": np.zeros(shape, np.int64),
                    "case_folder": np.full(shape, "", dtype=object)}
        for case in sweep.sweep_cases:
            result, at = results[case.case_id], case.position
            for name in ("pf", "pf_low", "pf_high", "fos_mean", "fos_std", "n_failed"):
                columns[name][at] = getattr(result, name)
            columns["n_decided"][at] = result.n_realisations - result.n_undecided
            columns["case_folder"][at] = case.case_id
        dataset = xr.Dataset(coords=coords)
        for name, values in columns.items():
            dataset[name] = PROBABILISTIC_SWEEP_FILE[name].over(dims, values)
        dataset.attrs = {"title": f"spfem-fos sweep of the probabilistic study {sweep.study.name}: pf of every case",
                         "Conventions": "CF-1.11", "study_name": sweep.study.name,
                         "sweep_combination": sweep.study.sweep.combination,
                         "sweep_axes": ", ".join(axis.path for axis in sweep.study.sweep.axes),
                         "n_cases": len(sweep.sweep_cases), **provenance(sweep.study)}
        study_path = sweep.out_dir / STUDY_FILE_NAME
        write_dataset(dataset, study_path)
        figures = []
        if sweep.study.output.figures:
            from workflows.probabilistic.figures import draw_pf_sweep  # matplotlib only when drawing

            figures = [draw_pf_sweep(sweep.out_dir, dataset)]
        timings_s = {"cases_elapsed": timings.cases_elapsed, "srf_runs_worker": timings.srf_runs_worker,
                     "total": time.perf_counter() - wall_start}
        return ProbabilisticSweepOutcome(sweep.out_dir, study_path, sweep.sweep_cases, results,
                                         sum(result.runs_made for result in results.values()), timings_s, figures)

    def report(self, sweep, outcome: ProbabilisticSweepOutcome, quiet: bool) -> Report:
        labels = list(outcome.cases[0].values)
        rows = []
        for case in outcome.cases:
            result = outcome.outcomes[case.case_id]
            rows.append([value_text(case.values[label]) for label in labels]
                        + [f"{result.pf:.4g} [{result.pf_low:.4g}, {result.pf_high:.4g}]",
                           f"{result.n_failed} / {result.n_realisations - result.n_undecided}"])
        table = fixed_width_table(labels + ["pf [95% interval]", "failed"], rows, len(labels))
        if quiet:
            return Report(table)
        header = (f"{sweep.study.name}: {len(outcome.cases)} probabilistic cases, {outcome.runs_made} SRF runs, "
                  f"wall time {outcome.timings_s['total']:.1f} s")
        wrote = (f"wrote {outcome.study_path}, {outcome.out_dir / CASES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        return Report([header, *table, wrote])

