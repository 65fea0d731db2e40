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
    WINDOW_ABOVE,
    WINDOW_BELOW,
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


@pytest.mark.parametrize("window", [(1.38, 1.42, 0.01), (1.33, 1.37, 0.01), (1.3, 1.36, 0.02), (1.4, 1.48, 0.02),
                                    (1.37, 1.41, 0.01)])
def test_a_window_that_misses_by_less_than_two_steps_costs_one_run_beyond_it(window):
    """The FOS 1.3742 just below or above the window, or in its first step with no room for a third run
    below the first failure (1.37 stable, 1.38 failed, one tolerance apart): one value twice the
    window's step beyond its end holds it (3-7 runs).  Before: the stage's full sweep joined on that
    side (8-10 runs, as many as the full search's 10), from srf_min upwards when the FOS lay below the
    window."""
    full, full_search = _search(None)
    made, search = _search(window)
    assert search.knee().fos_low <= FOS <= search.knee().fos_high
    assert abs(search.knee().fos - full_search.knee().fos) <= 0.01
    assert len(made) <= 7 < len(full)


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
    a prediction above srf_max places the window below it, not the full search of the range, and the window
    ends at srf_max (its values above would be runs above a failure)."""
    import dataclasses

    study = load_study(REPO / "studies" / "quickstart.toml")
    stage = study.strength_reduction
    case = Case(study, REPO, case_id="candidate", top_first=True)
    above = stage.srf_max + 0.3
    low, high, step = WindowPredictor().window(case, [0.0], above)
    width = WINDOW_BELOW + WINDOW_ABOVE
    assert high == pytest.approx(stage.srf_max) and low == pytest.approx(stage.srf_max - width * step)
    search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance, 1e-3, window=(low, high, step),
                       top_first=True)
    assert max(search.sweep) == stage.srf_max and min(search.sweep) == pytest.approx(stage.srf_max - width * step)
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
    assert step == 0.01 and low == pytest.approx(guess.fos - 0.01, abs=1e-4) and high == pytest.approx(low + 0.04)


@pytest.mark.parametrize("sigma, step", [(0.004, 0.01), (0.01, 0.01), (0.0101, 0.02), (0.033, 0.04), (0.04, 0.04),
                                         (0.05, 0.08)])
def test_a_windows_step_is_the_tolerance_times_a_power_of_two_at_least_the_expected_error(sigma, step):
    """The bracket a window leaves is one step, which bisection brings to the tolerance 0.01: 0.04 in two
    runs, as 0.033 would take.  Before: the step was sigma itself (0.033), missing more for no fewer runs."""
    low, high, found = search_window(Prediction(1.3, sigma, ""), 0.01)
    assert found == pytest.approx(step) and low == pytest.approx(1.3 - step) and high == pytest.approx(1.3 + 3 * step)


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


def test_a_realisation_of_a_field_is_estimated_on_its_weakest_circle_among_all_those_of_the_mean_soil(monkeypatch):
    """The undrained random-field study (h = 2 m) with cu at 30% of its mean in a band along one circle
    whose mean-soil F is 25% above the least: the realisation's estimate is at most that circle's F
    times 0.3 (circles along the band share its weakness), although the circle is not among the 40 least of the mean soil (before: those alone,
    read at equal steps of x: the estimate stayed near the least circle's F)."""
    from workflows.fos.critical_circle import candidate_circles
    from workflows.probabilistic import field_mechanisms
    from workflows.probabilistic.study_type import ProbabilisticStudy, Realisations
    from workflows.scene import cloud
    from workflows.study import parse_study

    text = (REPO / "studies" / "probabilistic_undrained.toml").read_text()
    text = (text.replace("spacing_m = 1.0", "spacing_m = 2.0").replace("realisations = 200", "realisations = 2")
            .replace('compute = "verdict"', 'compute = "fos"'))
    study = parse_study(text)
    circles = candidate_circles(study, 100_000)
    least = circles[0].fos
    weak = next(circle for circle in circles if circle.fos > 1.25 * least)
    assert weak not in circles[:40]
    node_xy_m, node_spacing_m = cloud(study)
    (xc, yc), radius = weak.centre_m, weak.radius_m
    low, high = sorted((weak.entry_x_m, weak.exit_x_m))
    band = ((np.abs(np.hypot(node_xy_m[:, 0] - xc, node_xy_m[:, 1] - yc) - radius) <= 1.5 * study.geometry.spacing_m)
            & (node_xy_m[:, 0] >= low - 2.0) & (node_xy_m[:, 0] <= high + 2.0) & (node_xy_m[:, 1] < yc))
    cu_pa = np.where(band, 0.3 * 50e3, 50e3)
    monkeypatch.setattr(field_mechanisms, "node_properties", lambda *args: {"cohesion_pa": cu_pa})
    case = Realisations(study).case(1)
    probabilistic = ProbabilisticStudy(study, Path("."))
    estimate = probabilistic._field_estimate(case.study)
    assert 0.3 * least <= estimate <= 1.01 * 0.3 * weak.fos < 0.6 * least


def test_the_full_sweep_joins_a_window_that_missed_twice_no_closer_than_its_step():
    """The 45 degree, 6 m slope of studies/sweep_geometry.toml (its displacements, interpolated): a
    window 1.2884-1.3284 below the FOS 1.364, its neighbour 1.3484 stable too.  Before, the stage's full
    sweep joined from 1.35, 0.0016 above 1.3484: that pair's rise per unit SRF was the steepest and the
    FOS 1.3492 (the full search's 1.3640).  Now the sweep joins from 1.5 and the bracket is refined
    about the FOS."""
    srf = [0.6, 0.9, 1.2, 1.2884, 1.3284, 1.3484, 1.35, 1.3594, 1.3687, 1.3875, 1.5]
    u_m = [1.8e-6, 2.0e-4, 2.21e-3, 4.19e-3, 6.35e-3, 1.013e-2, 1.084e-2, 1.933e-2, 4.611e-2, 0.1398, 0.6059]

    def search(window):
        found = SrfSearch(0.6, 3.0, 0.15, 0.01, 1e-5, n_parallel=1, failure_m=0.03, window=window)
        while True:
            values = found.next_values()
            if not values and not found.pending:
                return found
            for value in values:
                found.started(value)
                u = math.exp(np.interp(value, srf, np.log(u_m)))
                found.finished(RunOutcome(value, u, "failed" if u > 0.03 else "stable"))

    full, windowed = search(None).knee(), search((1.2884, 1.3284, 0.01))
    assert abs(windowed.knee().fos - full.fos) <= 0.01 and windowed.knee().fos_low >= 1.355
