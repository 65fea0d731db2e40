"""The FOS criterion on synthetic SRF-displacement curves, and the sweep-then-refine search.

Synthetic curves: a stable branch (displacement growing slowly with F) and a failure jump at
a known F*; uniform and non-uniform SRF spacing, a noisy stable branch, curves with no knee.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from workflows.fos.criterion import (
    brackets_agree,
    curvature,
    pick_fos,
    pick_knee,
    refinement_points,
    status_bracket,
)
from workflows.fos.search import RunOutcome, SrfSearch, sweep_values
from workflows.fos.verdict import DIVERGED, FAILED, STABLE

FLOOR_M = 1e-3


def slope_response(srf, f_star=1.3712, noise=0.0, seed=0):
    """Largest displacement (m) of a synthetic slope: 5 mm growing gently below F*, 2 m above."""
    srf = np.asarray(srf, dtype=float)
    rng = np.random.default_rng(seed)
    stable = 0.005 * np.exp(2.0 * (srf - 1.0)) * (1.0 + noise * rng.uniform(-1, 1, srf.shape))
    return np.where(srf > f_star, 2.0, stable)


def statuses(srf, f_star=1.3712):
    return [FAILED if f > f_star else STABLE for f in srf]


def test_curvature_is_exact_for_a_parabola_on_a_non_uniform_grid():
    # log10 u = x^2 on [0, 1]: normalised y = x^2, kappa = 2 / (1 + 4 x^2)^1.5 (3-point formulas are exact)
    x = np.array([0.0, 0.1, 0.25, 0.3, 0.55, 0.6, 0.9, 1.0])
    kappa = curvature(x, 10.0 ** (x**2), floor_m=1e-9)
    expected = 2.0 / (1.0 + 4.0 * x**2) ** 1.5
    assert np.isnan(kappa[[0, -1]]).all()
    np.testing.assert_allclose(kappa[1:-1], expected[1:-1], rtol=1e-12)


@pytest.mark.parametrize(
    "srf",
    [
        np.round(np.arange(1.0, 2.01, 0.1), 4),  # uniform
        np.array([0.8, 1.0, 1.05, 1.2, 1.25, 1.33, 1.42, 1.6, 1.9]),  # non-uniform
    ],
    ids=["uniform", "non-uniform"],
)
def test_knee_and_bracket_sit_on_the_jump(srf):
    u = slope_response(srf)
    fos = pick_fos(srf, u, srf, u, statuses(srf), FLOOR_M)
    below, above = srf[srf <= 1.3712].max(), srf[srf > 1.3712].min()
    assert (fos.fos_low, fos.fos_high) == (below, above)
    assert fos.fos == pytest.approx(0.5 * (below + above))
    assert pick_knee(srf, u, FLOOR_M).fos_low == below  # a sharp jump: the knee is the last stable sample


def test_noisy_stable_branch_does_not_move_the_bracket():
    srf = np.round(np.arange(0.8, 2.01, 0.1), 4)
    for seed in range(20):
        u = slope_response(srf, noise=0.3, seed=seed)
        fos = pick_fos(srf, u, srf, u, statuses(srf), FLOOR_M)
        assert fos.fos_low < 1.3712 < fos.fos_high, seed


def test_displacements_below_the_floor_make_no_knee():
    # decades of numerical noise far below the floor, then the jump: the knee is still the jump
    srf = np.round(np.arange(0.5, 1.61, 0.1), 4)
    u = np.where(srf > 1.25, 1.5, 10.0 ** np.linspace(-9, -5, srf.size))
    fos = pick_fos(srf, u, srf, u, statuses(srf, 1.25), FLOOR_M)
    assert (fos.fos_low, fos.fos_high) == (1.2, 1.3)


@pytest.mark.parametrize(
    "u, why",
    [(np.full(8, 0.01), "no convex upturn"), (np.full(8, 2.0), "no convex upturn"), (np.array([0.01, 2.0]), "at least 3")],
    ids=["all stable and flat", "all failed", "two runs"],
)
def test_no_knee_gives_nan_and_says_why(u, why):
    srf = np.linspace(1.0, 1.7, u.size)
    fos = pick_fos(srf, u, srf, u, [STABLE] * u.size, FLOOR_M)
    assert math.isnan(fos.fos) and why in fos.reason


def test_smooth_rise_brackets_its_steepest_part():
    # a logistic rise in log10 u centred at 1.4: no jump, the steepest point is the centre
    srf = np.round(np.arange(1.0, 1.81, 0.05), 4)
    u = 10.0 ** (-2.0 + 2.5 / (1.0 + np.exp(-(srf - 1.4) / 0.04)))
    verdicts = [FAILED if value > 0.3 else STABLE for value in u]
    fos = pick_fos(srf, u, srf, u, verdicts, FLOOR_M)
    assert fos.fos_low <= 1.4 <= fos.fos_high


def test_status_bracket_and_disagreement():
    srf = [1.0, 1.1, 1.2, 1.3, 1.4]
    verdict = status_bracket(srf, [STABLE, STABLE, FAILED, STABLE, FAILED])
    assert (verdict.fos_low, verdict.fos_high, verdict.non_monotone) == (1.1, 1.2, [1.3])
    assert "stable again at 1.3" in verdict.reason
    u = slope_response(srf, f_star=1.35)
    fos = pick_fos(srf, u, srf, u, statuses(srf, 1.35), FLOOR_M)  # bracket [1.3, 1.4]
    assert not brackets_agree(fos, verdict, tolerance=0.01)
    assert brackets_agree(fos, status_bracket(srf, statuses(srf, 1.35)), tolerance=0.01)


def test_refinement_points_need_no_more_runs_than_bisection():
    # width 0.1, tolerance 0.01: bisection needs 4 runs; a first round of 2 (3 x 2 x 2 = 12 >= 10) keeps 4
    assert refinement_points(1.3, 1.4, 0.01, max_points=2) == [1.3333, 1.3667]
    # width 0.0333: 2 runs by bisection; a round of 2 would divide by 3 only and need a third
    assert refinement_points(1.3333, 1.3667, 0.01, max_points=2) == [1.35]
    assert refinement_points(1.3333, 1.3444, 0.01, max_points=2) == [1.3388]  # one run halves it below 0.01
    assert refinement_points(1.30, 1.305, 0.01, max_points=2) == []
    assert refinement_points(1.0, 2.0, 0.01, max_points=1) == [1.5]
    # any bracket: the plan reaches the tolerance in ceil(log2(width / tolerance)) runs
    for width in (0.011, 0.02, 0.05, 0.1, 0.2, 0.37):
        low, high, runs = 1.0, 1.0 + width, 0
        while points := refinement_points(low, high, 0.01, max_points=2):
            runs += len(points)
            high = points[0]  # the worst case: the FOS in the first part of the split
        assert high - low <= 0.01 + 1e-4
        assert runs == math.ceil(math.log2(width / 0.01)), width
    assert sweep_values(0.8, 1.2, 0.1) == [0.8, 0.9, 1.0, 1.1, 1.2]


def drive(search: SrfSearch, response, f_star):
    """Run the search to the end, finishing runs in start order (as a 2-worker pool would)."""
    queue = []
    while True:
        for srf in search.next_values():
            search.started(srf)
            queue.append(srf)
        if not queue:
            return
        srf = queue.pop(0)
        u = float(response(srf))
        search.finished(RunOutcome(srf, u, FAILED if srf > f_star else STABLE))


@pytest.mark.parametrize("f_star", [0.93, 1.2345, 1.3712, 1.6789])
def test_search_converges_to_the_jump_within_the_tolerance(f_star):
    search = SrfSearch(0.8, 2.0, 0.1, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2)
    drive(search, lambda f: slope_response(f, f_star), f_star)
    fos = search.knee()
    assert fos.fos_low <= f_star < fos.fos_high
    assert fos.fos_high - fos.fos_low <= 0.01
    assert "within the tolerance" in search.stop_reason
    # values above the first failure are skipped, not run
    assert all(f > min(o.srf for o in search.outcomes.values() if o.status == FAILED) for f in search.skipped)
    assert len(search.outcomes) <= 20


@pytest.mark.parametrize("f_star", [1.1234, 1.3712, 1.4567])
def test_a_sweep_too_coarse_for_a_knee_is_made_denser(f_star):
    """srf 1 to 3 in steps of 0.5: stable at 1.0, failed at 1.5, two runs where the knee needs three;
    the sweep is made denser below the failure and the search ends on the jump as a fine one does."""
    search = SrfSearch(1.0, 3.0, 0.5, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2)
    drive(search, lambda f: slope_response(f, f_star), f_star)
    fos = search.knee()
    assert fos.fos_low <= f_star < fos.fos_high and fos.fos_high - fos.fos_low <= 0.01
    assert "within the tolerance" in search.stop_reason


def test_verdicts_agree_when_every_run_failed_or_none_did():
    """No FOS inside the runs by either criterion is agreement, not a warning."""
    srf = [1.0, 1.1, 1.2]
    for f_star in (0.5, 9.0):  # every run failed / none did
        u = slope_response(srf, f_star)
        fos = pick_fos(srf, u, srf, u, statuses(srf, f_star), FLOOR_M)
        assert math.isnan(fos.fos) and brackets_agree(fos, status_bracket(srf, statuses(srf, f_star)), 0.01)


def test_search_without_a_failure_stops_and_says_so():
    search = SrfSearch(1.0, 1.5, 0.1, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2)
    drive(search, lambda f: slope_response(f, 9.0), 9.0)
    assert sorted(search.outcomes) == [1.0, 1.1, 1.2, 1.3, 1.4, 1.5]
    assert math.isnan(search.knee().fos) and "no run failed" in search.stop_reason


def test_an_srf_max_off_the_step_grid_is_the_last_sweep_value_and_the_verdict_says_what_stopped():
    """srf_min 1, srf_step 0.3, srf_max 2: 2 was never run, and the verdict line blamed max_runs after 4
    runs.  The sweep now ends on srf_max; the verdict names max_runs only when the search stopped there."""
    from types import SimpleNamespace

    from workflows.fos.report import verdict_line

    assert sweep_values(1.0, 2.0, 0.3) == [1.0, 1.3, 1.6, 1.9, 2.0]
    for max_runs, words in ((40, "FOS > 2: no run failed up to srf_max = 2 (raise srf_max)"),
                            (3, "FOS > 1.6: no run failed, and the search stopped at max_runs = 3 after 3 runs")):
        stage = SimpleNamespace(srf_max=2.0, max_runs=max_runs)
        search = SrfSearch(1.0, 2.0, 0.3, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2, max_runs=max_runs)
        drive(search, lambda f: slope_response(f, 9.0), 9.0)
        runs = [SimpleNamespace(srf=o.srf, status=o.status) for _, o in sorted(search.outcomes.items())]
        status = status_bracket([r.srf for r in runs], [r.status for r in runs])
        line = verdict_line(search.knee(), status, True, runs, stage, search.stop_reason)
        assert line.startswith(words), line
    assert sorted(search.outcomes) == [1.0, 1.3, 1.6]


def test_search_respects_max_runs():
    search = SrfSearch(1.0, 2.0, 0.1, tolerance=1e-4, floor_m=FLOOR_M, n_parallel=2, max_runs=8)
    drive(search, lambda f: slope_response(f), 1.3712)
    assert len(search.outcomes) == 8 and "max_runs" in search.stop_reason


def drive_with_guesses(search: SrfSearch, response, f_star):
    """As ``drive``, but a worker left idle runs ``speculative_values``; a guess counts only
    once ``next_values`` asks for it.  (guesses started, guesses used)."""
    queue, guessed, used = [], {}, 0
    while True:
        planned = search.next_values()
        for srf in planned:
            search.started(srf)
            if srf in guessed:
                used += 1
                search.finished(guessed.pop(srf))
            else:
                queue.append(srf)
        if not queue:
            if planned:
                continue  # every value asked for was a finished guess: ask again
            return len(guessed) + used, used
        for srf in search.speculative_values(1):
            u = float(response(srf))
            guessed.setdefault(srf, RunOutcome(srf, u, FAILED if srf > f_star else STABLE))
        srf = queue.pop(0)
        search.finished(RunOutcome(srf, float(response(srf)), FAILED if srf > f_star else STABLE))


@pytest.mark.parametrize("f_star", [0.93, 1.2345, 1.3712, 1.6789])
def test_guesses_on_idle_workers_do_not_change_the_runs_used(f_star):
    def response(f):
        return slope_response(f, f_star)

    plain = SrfSearch(0.8, 2.0, 0.1, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2)
    drive(plain, response, f_star)
    guessing = SrfSearch(0.8, 2.0, 0.1, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2)
    started, used = drive_with_guesses(guessing, response, f_star)
    assert guessing.outcomes == plain.outcomes
    assert guessing.knee() == plain.knee()
    assert started >= 1 and 0 <= used <= started


# the reference slope's sweep (studies/reference_slope.toml, h = 0.3 m): largest displacement in m
REFERENCE_SWEEP_M = {1.0: 0.0076, 1.1: 0.0109, 1.2: 0.0191, 1.3: 0.0654, 1.4: 0.980}


def reference_search(finished: dict[float, float]) -> SrfSearch:
    search = SrfSearch(1.0, 2.0, 0.1, tolerance=0.01, floor_m=1.5e-3, n_parallel=2, failure_m=1.5)
    for srf, u in finished.items():
        search.started(srf)
        search.finished(RunOutcome(srf, u, STABLE))
    return search


def test_a_sweep_run_expected_to_fail_holds_back_the_sweep_and_the_idle_worker_guesses_the_refinement():
    search = reference_search(REFERENCE_SWEEP_M)
    search.started(1.5)
    # u(1.5) = 0.98 (0.98 / 0.0654)^1 = 14.7 m >= 1.5 m: 1.6 would be cancelled, so it waits
    assert search.predicted_failure() == 1.5
    assert search.next_values() == []
    guess = search.speculative_values(1)
    search.finished(RunOutcome(1.5, 1.52, FAILED))
    refinement = search.next_values()
    assert len(guess) == 1 and guess[0] in refinement and all(1.3 < f < 1.4 for f in refinement)


def test_an_expected_failure_that_comes_out_stable_releases_the_sweep():
    search = reference_search(REFERENCE_SWEEP_M)
    search.started(1.5)
    assert search.next_values() == []
    search.finished(RunOutcome(1.5, 1.2, STABLE))  # an arrested slide
    assert search.predicted_failure() == math.inf
    assert search.next_values() == [1.6, 1.7]


def test_no_failure_is_predicted_from_slowly_growing_displacements():
    search = reference_search({f: u for f, u in REFERENCE_SWEEP_M.items() if f <= 1.2})
    search.started(1.3)  # u(1.3) = 0.0191 (0.0191 / 0.0109) = 0.033 m: the sweep goes on
    assert search.predicted_failure() == math.inf
    assert search.next_values() == [1.4]
    assert search.speculative_values(1) == []


def accelerating_response(srf, f_star):
    """Largest displacement (m) rising ever faster towards F*, 2 m above it."""
    srf = np.asarray(srf, dtype=float)
    return np.where(srf > f_star, 2.0, 0.005 * np.exp(2.0 * (srf - 1.0)) + 0.4 * np.exp(25.0 * (srf - f_star)))


def plain_and_driven(f_star, driver) -> tuple[SrfSearch, SrfSearch]:
    """Two searches on ``accelerating_response``: one driven plainly, one by ``driver``."""
    def response(f):
        return accelerating_response(f, f_star)

    plain, driven = (SrfSearch(0.8, 2.0, 0.1, tolerance=0.01, floor_m=FLOOR_M, n_parallel=2, failure_m=1.0)
                     for _ in range(2))
    drive(plain, response, f_star)
    driver(driven, response, f_star)
    return plain, driven


@pytest.mark.parametrize("f_star", [0.93, 1.2345, 1.3712, 1.45, 1.6789])
def test_guesses_on_expected_failures_do_not_change_the_runs_used(f_star):
    plain, guessing = plain_and_driven(f_star, drive_with_guesses)
    assert guessing.outcomes == plain.outcomes
    assert guessing.knee() == plain.knee()
    fos = plain.knee()
    assert fos.fos_low <= f_star < fos.fos_high and fos.fos_high - fos.fos_low <= 0.01


def test_a_run_known_to_fail_holds_back_the_sweep_and_the_freed_worker_guesses_below_it():
    search = reference_search({f: u for f, u in REFERENCE_SWEEP_M.items() if f <= 1.3})
    for srf in (1.4, 1.5):  # released together: neither is expected to fail from the curve
        search.started(srf)
    assert search.predicted_failure() == math.inf and search.speculative_values(1) == []
    search.passed_failure(1.4)  # its largest displacement passed failure_m mid-run
    assert search.predicted_failure() == 1.4 == search.certain_failure()
    search.deferred(1.5)  # the engine stops the run above it
    assert search.next_values() == []  # 1.5 and up held back until 1.4 ends
    guesses = search.speculative_values(2)  # the failed branch only: the refinement below 1.4
    assert guesses and all(1.3 < f < 1.4 for f in guesses)
    search.finished(RunOutcome(1.4, 0.98, FAILED))
    assert search.next_values() == guesses
    assert "above the failed SRF 1.4" in search.skipped[1.5]


def test_a_run_known_to_fail_that_diverges_gives_the_runs_above_it_back():
    search = reference_search({f: u for f, u in REFERENCE_SWEEP_M.items() if f <= 1.3})
    for srf in (1.4, 1.5):
        search.started(srf)
    search.passed_failure(1.4)
    search.deferred(1.5)
    search.finished(RunOutcome(1.4, math.nan, DIVERGED))
    assert search.certain_failure() == math.inf
    assert search.next_values() == [1.5, 1.6] and 1.5 not in search.skipped


def drive_with_failure_signals(search: SrfSearch, response, f_star):
    """As ``drive_with_guesses``, and every run that will fail says so as soon as it starts
    (``passed_failure``); the runs above it are stopped (``deferred``), as the engine does."""
    queue, guessed = [], {}

    def outcome(srf):
        return RunOutcome(srf, float(response(srf)), FAILED if srf > f_star else STABLE)

    while True:
        planned = search.next_values()
        for srf in planned:
            search.started(srf)
            if srf in guessed:
                search.finished(guessed.pop(srf))
            else:
                queue.append(srf)
                if srf > f_star:
                    search.passed_failure(srf)
        for srf in [f for f in queue if f > search.certain_failure()]:
            queue.remove(srf)
            search.deferred(srf)
        if not queue:
            if planned:
                continue
            return
        for srf in search.speculative_values(1):
            guessed.setdefault(srf, outcome(srf))
        search.finished(outcome(queue.pop(0)))


@pytest.mark.parametrize("f_star", [0.93, 1.2345, 1.3712, 1.45, 1.6789])
def test_failures_known_early_do_not_change_the_fos(f_star):
    plain, signalled = plain_and_driven(f_star, drive_with_failure_signals)
    assert signalled.knee() == plain.knee()
    first_failure = plain.lowest_failed
    assert ({f: o for f, o in signalled.outcomes.items() if f <= first_failure}
            == {f: o for f, o in plain.outcomes.items() if f <= first_failure})
    assert len(signalled.outcomes) <= len(plain.outcomes)


@pytest.mark.parametrize("window", [None, (1.30, 1.38, 0.02)])
def test_a_search_that_runs_its_top_first_decides_as_the_full_search(window):
    """Subset simulation's candidate (``top_first``, srf_max its level's threshold b): stable at b, the search
    ends after that one run (FOS above b); failed, it goes on below b to the FOS.  Over F* on both sides of b,
    its verdict is the full search's (the full search's FOS above b exactly when the top-first one stopped
    at one run, but for F* within the tolerance of b) and its FOS is the full search's within the tolerance."""
    from workflows.fos.search import STABLE_AT_TOP

    tolerance, b = 0.002, 1.3456
    for f_star in np.round(np.linspace(1.2, 1.5, 61), 4):
        full = SrfSearch(0.5, 2.0, 0.1, tolerance=tolerance, floor_m=FLOOR_M, n_parallel=2, window=window)
        drive(full, lambda f, f_star=f_star: slope_response(f, f_star), f_star)
        top = SrfSearch(0.5, b, 0.1, tolerance=tolerance, floor_m=FLOOR_M, n_parallel=2, window=window, top_first=True)
        first = top.next_values()
        assert first == [b]  # the top alone, first
        drive(top, lambda f, f_star=f_star: slope_response(f, f_star), f_star)
        rejected = len(top.outcomes) == 1
        if abs(f_star - b) > tolerance:
            assert rejected == (full.knee().fos > b), f_star
        if rejected:
            assert top.outcomes[b].status == STABLE and top.stop_reason == STABLE_AT_TOP.format(b)
            assert math.isnan(top.knee().fos)
        else:
            fos = top.knee()
            assert fos.fos_low <= f_star < fos.fos_high <= b and fos.fos_high - fos.fos_low <= tolerance
            assert abs(fos.fos - full.knee().fos) <= tolerance, f_star


@pytest.mark.parametrize("window", [None, (1.20, 1.28, 0.02)])
def test_a_guard_below_the_top_ends_a_failed_top_between_them_and_otherwise_decides_as_the_full_search(window):
    """A top-first search with a guard g below its top b (subset simulation: a FOS above g is not needed): stable
    at b, one run; failed at b and stable at g, two runs and no FOS (the verdicts' bracket [g, b]); failed at g,
    the search goes on below g to the full search's FOS within the tolerance."""
    from workflows.fos.criterion import status_bracket
    from workflows.fos.search import STABLE_AT_GUARD

    tolerance, b, g = 0.002, 1.3456, 1.2711
    for f_star in np.round(np.linspace(1.1, 1.5, 81), 4):
        full = SrfSearch(0.5, 2.0, 0.1, tolerance=tolerance, floor_m=FLOOR_M, n_parallel=2, window=window)
        drive(full, lambda f, f_star=f_star: slope_response(f, f_star), f_star)
        guarded = SrfSearch(0.5, b, 0.1, tolerance=tolerance, floor_m=FLOOR_M, n_parallel=2, window=window,
                            top_first=True, guard=g)
        drive(guarded, lambda f, f_star=f_star: slope_response(f, f_star), f_star)
        runs = sorted(guarded.outcomes)
        if abs(f_star - b) > tolerance and abs(f_star - g) > tolerance:
            assert (runs == [b]) == (full.knee().fos > b), f_star
            assert (runs == [g, b]) == (g < full.knee().fos < b), f_star
        if runs == [g, b]:
            assert guarded.stop_reason == STABLE_AT_GUARD.format(g, b) and math.isnan(guarded.knee().fos)
            bracket = status_bracket(runs, [guarded.outcomes[f].status for f in runs])
            assert (bracket.fos_low, bracket.fos_high) == (g, b)
        elif runs != [b]:
            fos = guarded.knee()
            assert fos.fos_high <= g and abs(fos.fos - full.knee().fos) <= tolerance, f_star


def test_a_top_known_to_fail_lets_the_search_go_on_while_it_runs():
    """The run at the top passed the failure displacement (step 5): the runs below it start at once (one
    beside it on two workers)."""
    search = SrfSearch(0.5, 1.4, 0.1, tolerance=0.002, floor_m=FLOOR_M, n_parallel=2, window=(1.2, 1.3, 0.05),
                       top_first=True)
    assert search.next_values() == [1.4]
    search.started(1.4)
    assert search.next_values() == []
    search.passed_failure(1.4)
    assert search.next_values() == [1.2]
