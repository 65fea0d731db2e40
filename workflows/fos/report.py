"""The printed report of a strength-reduction study: a table of the runs and the verdict line."""

from __future__ import annotations

import math

from workflows.fos.search import STABLE_AT_TOP
from workflows.fos.slip_surface import CROSS_CHECK_MARGIN
from workflows.fos.verdict import DIVERGED, FAILED, STABLE


def verdict_line(knee, status, agree, runs, stage, stop_reason: str = "") -> str:
    """One line: the FOS or why there is none, and any warning (``runs``: the ``task.RunRecord``s by SRF;
    ``stop_reason``: why the search stopped, ``search.SrfSearch.stop_reason``)."""
    if not runs:
        return "no SRF run was made"
    failed_at_or_below_1 = [r.srf for r in runs if r.status == FAILED and r.srf <= 1.0]
    parts = []
    if math.isnan(knee.fos):
        if all(r.status == FAILED for r in runs if r.status != DIVERGED):
            parts.append(f"FOS < {runs[0].srf:g}: every run failed")
        elif all(r.status == STABLE for r in runs if r.status != DIVERGED):
            highest = max(r.srf for r in runs if r.status == STABLE)
            if stop_reason == STABLE_AT_TOP.format(highest):  # (a subset simulation's candidate: its threshold)
                parts.append(f"FOS > {highest:g}: {stop_reason}")
            elif stop_reason.startswith("stopped at max_runs"):
                parts.append(f"FOS > {highest:g}: no run failed, and the search stopped at max_runs = "
                             f"{stage.max_runs} after {len(runs)} runs, before srf_max = {stage.srf_max:g} (raise "
                             "max_runs or srf_step)")
            else:
                parts.append(f"FOS > {highest:g}: no run failed up to srf_max = {stage.srf_max:g} (raise srf_max)")
        else:
            parts.append(f"no FOS: {knee.reason}")
    else:
        parts.append(
            f"FOS = {knee.fos:.4g}, bracket [{knee.fos_low:.4g}, {knee.fos_high:.4g}] (steepest rise of the "
            f"displacement after the maximum-curvature knee at SRF {knee.knee_srf:g})"
        )
    if failed_at_or_below_1 or (not math.isnan(knee.fos) and knee.fos_high <= 1.0):
        parts.append("the slope is UNSTABLE AS BUILT (it fails at SRF <= 1)")
    if not agree:
        parts.append(f"WARNING: the run verdicts disagree ({status.reason})")
    elif status.non_monotone:
        parts.append(f"note: {status.reason}")
    return "; ".join(parts)


def report_lines(outcome) -> list[str]:
    """The printed report: a table of SRF, largest displacement and status, then the FOS."""
    lines = [f"{'SRF':>8}  {'max disp (m)':>12}  {'t end (s)':>9}  status", f"{'-' * 8}  {'-' * 12}  {'-' * 9}  ------"]
    for r in outcome.runs:
        lines.append(f"{r.srf:8.4f}  {r.max_displacement_m:12.4g}  {r.stop_time_s:9.3g}  {r.status}")
    lines.append(outcome.verdict)
    if outcome.stiffness_factor != 1.0:
        lines.append(f"the SRF runs used the moduli times {outcome.stiffness_factor:.3g}: the slope's elastic response "
                     "is the same small fraction of its height whatever its stiffness (the FOS does not depend on it)")
    if not math.isnan(outcome.status_high):
        lines.append(
            f"second criterion (run verdicts): FOS in [{outcome.status_low:.4g}, {outcome.status_high:.4g}]"
            + ("" if outcome.criteria_agree else "  <-- DISAGREES with the knee")
        )
    slip = getattr(outcome, "slip", None)
    if slip is not None and not isinstance(slip, str):
        (x_in, y_in), (x_out, y_out), le = slip.entry_m, slip.exit_m, slip.limit_equilibrium
        cross_check = (f"Spencer's limit-equilibrium FOS on it {le.fos:.4g}" if not math.isnan(le.fos)
                       else f"no limit-equilibrium FOS on it: {le.reason}")
        if math.isfinite(le.fos) and math.isfinite(outcome.fos) and abs(le.fos / outcome.fos - 1.0) > CROSS_CHECK_MARGIN:
            cross_check += (f", {100 * (le.fos / outcome.fos - 1.0):+.0f}% from the FOS: more than "
                            f"{100 * CROSS_CHECK_MARGIN:.0f}%, so the line may not be the mechanism (see the fields "
                            "of the failed run)")
        lines.append(f"slip surface (SRF {slip.srf:g}): entry ({x_in:.4g}, {y_in:.4g}) m, exit ({x_out:.4g}, "
                     f"{y_out:.4g}) m, {slip.depth_m:.3g} m deep, {slip.area_m2:.3g} m2; {cross_check}")
    for contact in getattr(outcome, "edges", []):
        lines.append(("WARNING, the box decides: " if contact.warning else "note: ") + contact.line)
    return lines
