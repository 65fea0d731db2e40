"""The numerical stability stress suite (verification/stress_suite.py): every case must end as expected.

The full suite (21 cases, a few minutes) is slow; the CFL cases run by default: accepted
steps are stable, steps past the limit are refused, and steps forced past it are stopped by
the divergence detection instead of producing garbage."""

from __future__ import annotations

import pytest

from verification.stress_suite import case_cfl, run_suite


@pytest.mark.parametrize(
    "cfl, force, expected",
    [(0.5, False, "stable"), (0.95, False, "refused"), (2.0, True, "diverged"), (3.0, True, "diverged")],
)
def test_cfl_past_the_limit_is_refused_or_stopped(cfl, force, expected):
    result = case_cfl(cfl, force=force)
    assert result.outcome == expected, result


@pytest.mark.slow
def test_every_stress_case_ends_as_expected():
    results = run_suite(progress=lambda line: None)
    assert [r for r in results if not r.ok] == []
