"""A sweep of refinement studies: a study with ``[sweep]`` and ``[refinement]`` refines every case.

It is the sweep of ``workflows.sweep.nested`` over ``RefinementStudy``:

1. each case of the sweep is a refinement study of its own in ``OUT/cases/<case>/``: its study
   text ``case.toml`` (a refinement study that runs alone, and reuses the sweep's levels), its levels
   under ``levels/``, its ``refinement.nc`` and convergence figure, exactly as the study alone
   would write them (and reused by the next invocation while their keys hold);
2. the cases advance together, a level per round: the first level of every case, then each case's
   next level (or its current level in a grown window) as soon as the round is done, all on one
   cluster, gravity as tasks.  A case whose gravity diverges is recorded and the sweep goes on;
3. :class:`RefinedSweep` writes ``OUT/study.nc`` (the sweep's variables for each case's finest level, and the
   extrapolation: ``workflows.output.variables.REFINED_SWEEP_FILE``) and the design charts last.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from workflows.cases import CaseTimings, Report
from workflows.output.writing import write_dataset
from workflows.refinement.results import refined_sweep_dataset
from workflows.refinement.study_type import RefinementOutcome
from workflows.study.reading import SweepCase
from workflows.sweep.figures import draw_sweep_figures
from workflows.sweep.nested import SweepSummary
from workflows.sweep.report import fixed_width_table, value_text
from workflows.sweep.results import CASES_FOLDER, STUDY_FILE_NAME, CaseResult, case_result, diverged_result


@dataclass
class RefinedSweepOutcome:
    """What a sweep of refinement studies did and found."""

    out_dir: Path
    study_path: Path
    cases: list[SweepCase]
    refinements: dict[str, RefinementOutcome | None]  # by case id; None: its gravity diverged
    results: dict[str, CaseResult]  # the finest level of each case, by case id
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class RefinedSweep(SweepSummary):
    """What a sweep of refinement studies writes and prints (module doc, step 3)."""

    label = "a sweep of refinement studies"

    def conclude(self, sweep, concluded: dict, own: dict, timings: CaseTimings,
                 wall_start: float) -> RefinedSweepOutcome:
        """``study.nc`` with each case's finest level and its band (a case whose gravity diverged: its
        row diverged), and the design charts."""
        refinements: dict = {}
        results: dict = {}
        for case_id, refinement in sweep.studies.items():
            outcome = concluded[case_id]
            if outcome.diverged:
                refinements[case_id] = None
                results[case_id] = diverged_result(f"the gravity stage diverged: {outcome.error}", 0)
                continue
            refinements[case_id] = outcome.result
            finest = (refinement.found[max(refinement.found)] if refinement.found else
                      next(iter(own[case_id].values())).result)
            results[case_id] = case_result(finest)
        study_path = sweep.out_dir / STUDY_FILE_NAME
        dataset = refined_sweep_dataset(sweep.study, sweep.sweep_cases, results, refinements)
        write_dataset(dataset, study_path)
        figures = []
        if sweep.study.output.figures:
            figures = draw_sweep_figures(sweep.out_dir, dataset)
        timings_s = {"cases_elapsed": timings.cases_elapsed, "gravity_worker": timings.gravity_worker,
                     "srf_runs_worker": timings.srf_runs_worker, "total": time.perf_counter() - wall_start}
        return RefinedSweepOutcome(sweep.out_dir, study_path, sweep.sweep_cases, refinements, results, timings_s,
                                   figures)

    def report(self, sweep, outcome: RefinedSweepOutcome, quiet: bool) -> Report:
        labels = list(outcome.cases[0].values)
        rows = []
        for case in outcome.cases:
            refinement, finest = outcome.refinements[case.case_id], outcome.results[case.case_id]
            x = refinement.band if refinement is not None else None
            levels = " ".join(f"{level.fos:.4f}" if math.isfinite(level.fos) else "-"
                              for level in (refinement.levels if refinement is not None else []))
            band = f"{x.fos:.4f} +- {x.uncertainty:.4f}" if x is not None else "-"
            status = (("trusted" if x.trusted else "not trusted") if x is not None else
                      (refinement.message if refinement is not None else finest.status))
            rows.append([value_text(case.values[label]) for label in labels] + [levels, band, status])
        table = fixed_width_table(labels + ["FOS per level", "FOS at h -> 0 (95%)", "band"], rows, len(labels))
        if quiet:
            return Report(table)
        header = f"{sweep.study.name}: {len(outcome.cases)} cases refined, wall time {outcome.timings_s['total']:.1f} s"
        wrote = (f"wrote {outcome.study_path}, {outcome.out_dir / CASES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        return Report([header, *table, wrote])

