"""The printed report of a sweep: one row per case."""

from __future__ import annotations

import math

from workflows.study.reading import SweepCase
from workflows.sweep.results import ABOVE, BELOW, FOUND, CaseResult


def value_text(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    return str(value)


def _fos(result: CaseResult) -> str:
    if result.status == FOUND:
        return f"{result.fos:.4g}"
    if result.status == ABOVE:
        return f"> {result.fos_low:g}"
    if result.status == BELOW:
        return f"< {result.fos_high:g}"
    return "-"


def _bracket(result: CaseResult) -> str:
    return f"[{result.fos_low:.4g}, {result.fos_high:.4g}]" if math.isfinite(result.fos) else ""


def table_lines(cases: list[SweepCase], results: dict[str, CaseResult]) -> list[str]:
    """A fixed-width table: the axis values, FOS, bracket, runs and status of each case."""
    labels = list(cases[0].values)
    rows = [[value_text(case.values[label]) for label in labels]
            + [_fos(r := results[case.case_id]), _bracket(r), str(r.n_runs),
               r.status + ("" if r.criteria_agree or r.status != FOUND else " (verdicts disagree)")]
            for case in cases]
    header = labels + ["FOS", "bracket", "runs", "status"]
    widths = [max(len(header[i]), *(len(row[i]) for row in rows)) for i in range(len(header))]
    line = "  ".join(h.rjust(w) if i < len(labels) + 3 else h for i, (h, w) in enumerate(zip(header, widths)))
    lines = [line, "  ".join("-" * w for w in widths)]
    for row in rows:
        lines.append("  ".join(c.rjust(w) if i < len(labels) + 3 else c for i, (c, w) in enumerate(zip(row, widths))))
    return lines


def fixed_width_table(header: list[str], rows: list[list[str]], n_right: int) -> list[str]:
    """Fixed-width lines: the first ``n_right`` columns right-aligned, the rest left."""
    widths = [max(len(header[i]), *(len(row[i]) for row in rows)) for i in range(len(header))]

    def line(cells):
        return "  ".join(c.rjust(w) if i < n_right else c for i, (c, w) in enumerate(zip(cells, widths)))

    return [line(header), "  ".join("-" * w for w in widths), *(line(row) for row in rows)]


STAGE_SWEEP_COLUMNS = (("runout_m", "runout (m)"), ("retrogression_m", "retrogression (m)"),
                       ("sliding_mass_area_m2", "sliding mass (m2)"), ("time_to_rest_s", "at rest (s)"))
"""The runout metrics the printed table of a stage sweep shows, per runout stage."""


def stage_table_lines(outcome) -> list[str]:
    """A fixed-width table of a stage study's sweep (``workflows.sweep.study_type.StageSweepOutcome``): the axis
    values, then per runout stage its runout, retrogression, sliding mass and time to rest (- when still
    moving at the end), the status."""
    labels = list(outcome.cases[0].values)
    stages = outcome.runout_stages
    header = labels + [f"{stage} {title}" if len(stages) > 1 else title
                       for stage in stages for _, title in STAGE_SWEEP_COLUMNS] + ["status"]
    rows = []
    for case in outcome.cases:
        result = outcome.results[case.case_id]
        cells = [value_text(case.values[label]) for label in labels]
        for stage in stages:
            metrics = result.runout.get(stage, {})
            cells += [f"{metrics[key]:.4g}" if math.isfinite(metrics.get(key, math.nan)) else "-"
                      for key, _ in STAGE_SWEEP_COLUMNS]
        rows.append(cells + [result.status])
    return fixed_width_table(header, rows, len(header) - 1)
