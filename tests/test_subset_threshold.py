"""Subset simulation's per-level verdict (``workflows.probabilistic.subset_study``): a chain's candidate is
searched with its level's threshold as its ``srf_max``, run first (``fos.search``, step 6).  Driven without
dask: every point's search is an ``SrfSearch`` on a scripted slope whose FOS is proportional to cu (the
undrained slope with one lognormal cu, F* = F_det cu / mean cu), against the same study with every point's
full search (the reference: what the study did before)."""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import pytest

from verification.undrained_variants import shipped_text, single_variable_text
from workflows.fos.criterion import status_bracket
from workflows.fos.search import RunOutcome, SrfSearch
from workflows.fos.verdict import FAILED, STABLE
from workflows.study import parse_study

F_DET = 1.46
MEAN_CU_PA = 50e3


def _study_text(seed: int) -> str:
    """One lognormal cu (COV 0.12: pf near 1e-3 at factor 1), 100 points a level, h = 2 m."""
    text = single_variable_text(shipped_text(2.0), 0.12, 2000)
    text = re.sub(r'(?m)^method = .*$', 'method = "subset_simulation"\nsamples_per_level = 100', text, count=1)
    text = re.sub(r"(?m)^seed = 1$", f"seed = {seed}", text, count=1)
    return re.sub(r'(?m)^compute = .*$', 'compute = "fos"', text, count=1)


def _searched(stage, f_star: float, top_first: bool, guard: float | None = None):
    """A concluded case (``cases.Concluded``) of the stage's search on a slope that fails above ``f_star``
    (5 mm growing gently below it, 2 m above), runs finished in start order, and its number of runs."""
    from workflows.cases import Concluded

    search = SrfSearch(stage.srf_min, stage.srf_max, stage.srf_step, stage.fos_tolerance, 1e-3, n_parallel=2,
                       max_runs=stage.max_runs, top_first=top_first, guard=guard)
    queue: list[float] = []
    while True:
        for srf in search.next_values():
            search.started(srf)
            queue.append(srf)
        if not queue:
            break
        srf = queue.pop(0)
        failed = srf > f_star
        search.finished(RunOutcome(srf, 2.0 if failed else 0.005 * math.exp(2.0 * (srf - 1.0)),
                                   FAILED if failed else STABLE))
    knee = search.knee()
    runs = [SimpleNamespace(srf=o.srf, status=o.status) for o in search.outcomes.values()]
    status = status_bracket([r.srf for r in runs], [r.status for r in runs])
    return Concluded(SimpleNamespace(runs=runs, fos=knee.fos, fos_low=knee.fos_low, fos_high=knee.fos_high,
                                     criteria_agree=True, knee_srf=knee.knee_srf, n_particles=0, verdict="",
                                     status_low=status.fos_low, status_high=status.fos_high)), len(runs)


def _levels(tmp_path, seed: int, per_level_verdict: bool):
    """The study driven to its end: (the study type, each point's runs, its F*)."""
    from workflows.cases import RunOptions
    from workflows.probabilistic.subset_study import SubsetStudy
    from workflows.progress import Progress
    from workflows.study_types import study_type

    kind = study_type(parse_study(_study_text(seed)), tmp_path)
    assert isinstance(kind, SubsetStudy)
    kind.check(RunOptions(workers=1))
    cases = kind.cases()
    points, outcomes, runs, f_star = kind.realisations, {}, {}, {}
    base = points.study_of(0, text=False).strength_reduction
    while True:
        while cases:  # a round, generation by generation (the scripted searches take no window)
            for case in cases:
                i = case.position[0]
                assert points.case_id(i) not in outcomes  # each point is searched once
                stage, top_first, guard = base, False, None
                if per_level_verdict and case.top_first:  # its case as the study makes it
                    stage, top_first, guard = case.study.strength_reduction, True, case.guard
                    assert stage.srf_max == points.srf_max[i] and stage.srf_min == base.srf_min
                f_star[i] = F_DET * float(points.values[i, 0]) / MEAN_CU_PA
                outcomes[points.case_id(i)], runs[i] = _searched(stage, f_star[i], top_first, guard)
            kind.n_concluded += len(cases)
            cases = kind.more_cases(10**6)
        cases = kind.next_cases(outcomes, Progress())
        if not cases and kind.finished:
            return kind, runs, f_star


@pytest.fixture(scope="module")
def driven(tmp_path_factory):
    """:func:`_levels` of (seed, per_level_verdict), each driven once for the tests that read it."""
    done: dict = {}

    def levels(seed: int, per_level_verdict: bool):
        if (seed, per_level_verdict) not in done:
            done[seed, per_level_verdict] = _levels(tmp_path_factory.mktemp("levels"), seed, per_level_verdict)
        return done[seed, per_level_verdict]

    return levels


@pytest.mark.parametrize("seed", [1, 2])
def test_the_per_level_verdict_gives_the_full_searches_levels_at_fewer_runs(driven, seed):
    """The same thresholds (within the search's tolerance), the same accepted candidates, the same pf; every
    rejected candidate cost one run (before: a whole search), and the study fewer runs."""
    from workflows.probabilistic.subset_study import threshold_srf

    reference, reference_runs, _ = driven(seed, False)
    study, runs, f_star = driven(seed, True)
    assert study.realisations.count == reference.realisations.count
    thresholds = [level["threshold"] for level in study.levels]
    assert len(thresholds) == len(reference.levels) >= 3
    assert thresholds == pytest.approx([level["threshold"] for level in reference.levels], abs=0.002)
    assert study.accepted == reference.accepted
    assert study.levels[-1]["fraction"] == reference.levels[-1]["fraction"]
    rejected = [i for i in study.level_of if study.level_of[i] > 0 and i not in study.accepted]
    assert rejected and all(runs[i] == 1 for i in rejected)
    assert study.threshold_verdicts == len(rejected)
    assert all(reference_runs[i] > 3 for i in rejected)
    for i in study.accepted:  # an accepted candidate's FOS lies below its threshold, failed there
        if study.level_of[i] > 0:
            level = study.levels[study.level_of[i] - 1]
            assert study.level_fos[i] < level["threshold"] <= threshold_srf(level["threshold"])
            if i in study.between:  # stable at its guard: known only to lie above it
                assert study.level_fos[i] == study.guards[i] < f_star[i] + 0.002 and runs[i] == 2
            else:
                assert abs(study.level_fos[i] - f_star[i]) <= 0.002
    assert sum(runs.values()) < 0.8 * sum(reference_runs.values())


def test_a_threshold_onto_the_srf_grid_rounds_up_and_an_infinite_one_stops_the_study_naming_srf_max(tmp_path):
    """b_k rounded up onto the 1e-4 grid (stable there: a FOS above b_k).  A threshold that is infinite (more
    than 1 - p0 of the level above srf_max, whose FOS is only known to be above it) ended in an overflow, then
    gave the next level every point below srf_max as if it were a p0 share: a biased pf.  It stops the study,
    no pf, naming the field to raise."""
    from workflows.cases import RunOptions
    from workflows.probabilistic.subset_study import threshold_srf
    from workflows.progress import Progress
    from workflows.study_types import study_type

    assert threshold_srf(1.2007) == 1.2007 and threshold_srf(1.20071) == 1.2008 and threshold_srf(1.0) == 1.0
    kind = study_type(parse_study(_study_text(1)), tmp_path)
    kind.check(RunOptions(workers=1))
    kind.cases()
    samples = list(range(100))
    kind.level_fos = {i: (1.3 + 0.001 * i if i < 5 else math.inf) for i in samples}
    kind._finish_level(samples, Progress())
    assert kind.finished and not kind.chains
    assert "raise stages.srf.srf_max" in kind.stop_reason and "above srf_max = 2" in kind.stop_reason


@pytest.mark.parametrize("seed", [1, 2])
def test_level_0_searches_its_lowest_predicted_points_and_runs_the_others_top_first(driven, seed):
    """Level 0 needs its N p0 + 1 lowest FOS exactly: the 2 (N p0 + 1) points of lowest predicted FOS are searched
    in full, every other one runs its top first (the N p0 + 1-th lowest FOS found, at least) and stops there when
    stable (one run; before: every point a whole search).  The same threshold and seeds as full searches."""
    from workflows.probabilistic.subset_study import threshold_srf

    reference, reference_runs, _ = driven(seed, False)
    study, runs, f_star = driven(seed, True)
    n = 100
    first = study.level0_order[:study.level0_first]
    assert study.level0_first == 22 and sorted(study.level0_order) == list(range(n))
    second = [i for i in range(n) if i not in first]
    assert study.levels[0]["threshold"] == pytest.approx(reference.levels[0]["threshold"], abs=0.002)
    lowest = sorted(range(n), key=lambda i: f_star[i])[:11]
    top = study.level0_top
    assert math.isfinite(top) and top >= sorted(f_star[i] for i in first)[10] - 0.002
    assert all(study.realisations.srf_max[i] == threshold_srf(top) for i in second)
    stable = [i for i in second if f_star[i] > study.realisations.srf_max[i]]
    assert stable and all(runs[i] == 1 for i in stable) and study.level0_verdicts == len(stable)
    assert all(math.isfinite(study.level_fos[i]) for i in lowest)  # the N p0 + 1 lowest: found, every one
    assert sum(runs[i] for i in range(n)) < 0.6 * sum(reference_runs[i] for i in range(n))


@pytest.mark.parametrize("quantile", [None, 0.0])
def test_a_candidate_between_its_guard_and_the_threshold_costs_two_runs_and_the_levels_stay(driven, tmp_path,
                                                                                             monkeypatch, quantile):
    """A chain's candidate runs its level's threshold, then its guard (a quantile of the seeds' FOS, at least the factor):
    stable at the guard, it is accepted after two runs, its FOS known only as above the guard (before: a whole
    search below the threshold).  Where fewer than N p0 + 1 of a level's samples lie below its guard (forced here by
    a guard at the lowest seed), those between are searched again below it as new points: the levels are the full
    searches' either way."""
    from workflows.probabilistic import subset

    reference, reference_runs, _ = driven(1, False)  # (full searches: no guard run, none between)
    if quantile is None:
        study, runs, f_star = driven(1, True)
    else:
        monkeypatch.setattr(subset, "guard_quantile", lambda n_seeds, p0: quantile)
        study, runs, f_star = _levels(tmp_path / "guard", 1, per_level_verdict=True)
    assert study.guard_verdicts > 0
    # the copies take point numbers, so the candidates after them are other draws: compare up to their level
    same = min([study.level_of[j] for j in study.copy_of] + [len(study.levels) - 1])
    assert [level["threshold"] for level in study.levels[:same + 1]] == pytest.approx(
        [level["threshold"] for level in reference.levels[:same + 1]], abs=0.002)
    assert ({i for i in study.accepted if study.level_of[i] <= same}
            == {i for i in reference.accepted if reference.level_of[i] <= same})
    if quantile is None:
        assert not study.copy_of and study.between and same == len(study.levels) - 1
        assert study.levels[-1]["fraction"] == reference.levels[-1]["fraction"]
        assert all(runs[i] == 2 for i in study.between)
    else:  # every candidate between its guard and the threshold searched again: each copy's FOS is its candidate's
        assert study.copy_of
        assert all(study.level_fos[j] == study.level_fos[i] and abs(study.level_fos[i] - f_star[i]) <= 0.002
                   for j, i in study.copy_of.items())


def test_a_guard_quantile_keeps_p0_below_it_by_its_margin():
    """q - z sqrt(q (1 - q) / n) >= p0 at the least such q: 0.5 for 10 seeds (N = 100, p0 = 0.1), lower with more
    seeds, never below p0; 1 (no guard) where even q near 1 does not hold it."""
    from workflows.probabilistic.subset import GUARD_MARGIN_Z, guard_quantile

    for n in (10, 68, 200):
        q = guard_quantile(n, 0.1)
        assert q - GUARD_MARGIN_Z * math.sqrt(q * (1 - q) / n) >= 0.1
        assert (q - 0.01) - GUARD_MARGIN_Z * math.sqrt((q - 0.01) * (1 - q + 0.01) / n) < 0.1
    assert guard_quantile(10, 0.1) == 0.5 and 0.1 < guard_quantile(200, 0.1) < guard_quantile(68, 0.1) < 0.5
    assert guard_quantile(1, 0.8) == 1.0
