"""The printed report of a sweep: one row per case."""

from __future__ import annotations

import math

from workflows.study.reading import SweepCase
from workflows.sweep.results import ABOVE, BELOW, FOUND, CaseResult


def _value(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
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
    rows = [[_value(case.values[label]) for label in labels]
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
