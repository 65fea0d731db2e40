"""Fewer runs per answer (``workflows.fos.prediction``, ``workflows.fos.search``): a search that starts in
a window about a predicted FOS finds the FOS a full sweep finds, within the tolerance, in fewer runs,
and a window that misses grows until it holds it; the cases of a study come in a fixed order and
generations, so that what is predicted does not depend on the workers."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from workflows.cases import Case
from workflows.fos.prediction import (
    NO_CASE_SIGMA,
    FosPredictor,
    PredictedFeed,
    Prediction,
    WindowPredictor,
    maximin_order,
    search_window,
)
from workflows.fos.search import RunOutcome, SrfSearch, sweep_values
from workflows.study import load_study

REPO = Path(__file__).resolve().parents[1]

FOS = 1.3742


def _displacement(srf: float) -> float:
    """A slope whose contained displacement grows towards its FOS and jumps past it."""
    return 0.02 * (srf / FOS) ** 30 if srf < FOS else 0.06 + 5.0 * (srf - FOS)


def _search(window) -> tuple[list[float], SrfSearch]:
    search = SrfSearch(1.0, 2.0, 0.1, 0.01, 1e-5, n_parallel=2, failure_m=0.05, window=window)
    made = []
    while True:
        values = search.next_values()
        if not values and not search.pending:
            return made, search
        for srf in values:
            search.started(srf)
            made.append(srf)
        for srf in sorted(search.pending):
            u = _displacement(srf)
            search.finished(RunOutcome(srf, u, "failed" if u > 0.05 else "stable"))


@pytest.mark.parametrize("window", [(1.35, 1.39, 0.01), (1.2, 1.28, 0.02), (1.45, 1.53, 0.02), (1.0, 1.04, 0.01)])
def test_a_windowed_search_finds_the_full_sweeps_fos_and_a_window_that_misses_grows(window):
    full, full_search = _search(None)
    made, search = _search(window)
    fos, expected = search.knee(), full_search.knee()
    assert fos.fos_low <= FOS <= fos.fos_high and expected.fos_low <= FOS <= expected.fos_high
    assert abs(fos.fos - expected.fos) <= 0.01
    if window[0] < FOS < window[1]:
        assert len(made) <= 5 < len(full)
    assert all(1.0 <= srf <= 2.0 for srf in made)


@pytest.mark.parametrize("window", [(1.0, 1.01, 0.002), (1.9, 1.95, 0.002), (6.0e13, 7.0e13, 1e12), (0.01, 0.02, 0.005)])
def test_a_window_far_from_the_fos_or_beyond_the_range_costs_no_more_than_the_full_sweep(window):
    """Before: a window wholly above srf_max ran SRF values up to 6e13 (its ends were clamped apart), and
    a window far below the FOS grew at its own fine step (40 runs on a drawdown case whose full sweep
    took 9).  Now both ends lie in [srf_min, srf_max], and a window that misses costs its own runs
    besides the full sweep's."""
    full, _ = _search(None)
    made, search = _search(window)
    assert all(1.0 <= srf <= 2.0 for srf in made)
    assert search.knee().fos_low <= FOS <= search.knee().fos_high
    assert len(made) <= len(full) + len(sweep_values(*search.window))


def test_a_prediction_outside_the_stages_range_gives_the_full_search():
    """A limit-equilibrium estimate that missed the mechanism (7e13 on a vertical cut before its face
    was seen) predicts no window, and a concluded case whose FOS is far from its estimate joins no fit."""
    study = load_study(REPO / "studies" / "quickstart.toml")
    case = Case(study, REPO, case_id="far")
    assert WindowPredictor().window(case, [0.0], 7.0e13) is None
    assert WindowPredictor().window(case, [0.0], 1.4) is not None
    predictor = FosPredictor()
    predictor.observe([0.0], 7.0e13, 0.76)
    assert predictor.ratios == []


def test_a_case_that_runs_its_top_first_is_predicted_below_it():
    """A subset simulation's candidate searches on only once its srf_max (its level's threshold) has failed:
    a prediction above srf_max places the window below it, not the full search of the range."""
    import dataclasses

    study = load_study(REPO / "studies" / "quickstart.toml")
    stage = study.strength_reduction
    case = Case(study, REPO, case_id="candidate", top_first=True)
    above = stage.srf_max + 0.3
    low, high, step = WindowPredictor().window(case, [0.0], above)
    assert high == pytest.approx(stage.srf_max + 2 * step) and low == pytest.approx(stage.srf_max - 2 * step)
    search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance, 1e-3, window=(low, high, step),
                       top_first=True)
    assert max(search.sweep) == stage.srf_max and min(search.sweep) == pytest.approx(stage.srf_max - 2 * step)
    assert WindowPredictor().window(dataclasses.replace(case, top_first=False), [0.0], above) is None


def test_the_predictor_fits_the_ratio_to_limit_equilibrium_and_knows_its_error():
    """F = E (1.02 + 0.05 x): exact once four cases are known; before, limit equilibrium alone (6%),
    one case's ratio, the mean of two."""
    predictor = FosPredictor()
    first = predictor.predict([0.0], 1.3)
    assert first == Prediction(1.3, NO_CASE_SIGMA * 1.3, "limit equilibrium")
    for x in (0.0, 1.0, 2.0, 3.0):
        predictor.observe([x], 1.3 + 0.1 * x, (1.3 + 0.1 * x) * (1.02 + 0.05 * x))
    guess = predictor.predict([1.5], 1.45)
    assert guess.fos == pytest.approx(1.45 * (1.02 + 0.05 * 1.5)) and guess.sigma == pytest.approx(0.004 * 1.45)
    low, high, step = search_window(guess, 0.01)
    assert step == 0.01 and low < guess.fos < high and high - low == pytest.approx(0.04)


def test_a_grid_comes_corners_first_and_in_generations_predicted_from_earlier_ones_only():
    grid = list(itertools.product([5e3, 10e3, 15e3], [15.0, 20.0, 25.0]))
    order = maximin_order(np.array(grid))
    corners = {(5e3, 15.0), (5e3, 25.0), (15e3, 15.0), (15e3, 25.0)}
    assert {grid[i] for i in order[:4]} == corners and grid[order[4]] == (10e3, 20.0)

    class _Case:  # what the feed needs of a case
        def __init__(self, i):
            self.case_id = f"case{i}"
            self.study = None

    cases = [_Case(i) for i in range(len(grid))]
    feed = PredictedFeed(cases, [[c, math.tan(math.radians(p))] for c, p in grid])
    feed.windows.window = lambda case, features, estimate=None: None  # no section to estimate: generations alone
    sizes = []
    while feed.to_come():
        given = feed.more(100)
        assert feed.more(100) == []  # nothing more until the generation has concluded
        sizes.append(len(given))
        for case in given:
            feed.concluded(case.case_id, 1.0)
    assert sizes == [1, 2, 4, 2]


def test_a_case_handed_out_late_in_its_generation_is_predicted_from_the_earlier_generations_alone():
    """Generation 3 (four cases) handed out two at a time: the later two see what the first two did
    not (before: the first two's FOS, which had concluded by then), so the windows, runs and FOS of
    a sweep depended on how many cases the workers asked for at once."""

    class _Case:
        def __init__(self, i):
            self.case_id = f"case{i}"
            self.study = None

    cases = [_Case(i) for i in range(7)]
    feed = PredictedFeed(cases, [[float(i)] for i in range(7)])
    observed, seen = [], {}

    def window(case, features, estimate=None):  # what the predictor had observed when the case was handed out
        seen[case.case_id] = sorted(observed)

    def concluded(case_id, fos):
        observed.append(case_id)

    feed.windows.window, feed.windows.concluded = window, concluded
    for count in (1, 2, 2, 2):  # generations 1, 2, then the four of generation 3 in two calls
        for case in feed.more(count):
            feed.concluded(case.case_id, 1.0)
    first_three = sorted(case.case_id for case in feed.cases[:3])
    assert [seen[case.case_id] for case in feed.cases[3:7]] == [first_three] * 4
