"""A probabilistic study by subset simulation (``method = "subset_simulation"``, random variables and random
fields, ``compute = "fos"``): the levels of ``workflows.probabilistic.subset`` on the points' FOS.

Level 0 is the Monte Carlo sample of a ``monte_carlo`` study of the same seed (point i's standard
normals from the stream ``SeedSequence([seed, i])``, its fields those of realisation i),
``samples_per_level`` points.  Each later level runs its ``samples_per_level * p0`` chains together: a
round is one candidate per chain (its noise from the stream ``SeedSequence([seed, i, 1])`` of the
candidate's own number i, and for the fields the vector of realisation i's own field stream: the
candidate's fields are ``random_field.combination``, rho times the state's terms and sqrt(1 - rho^2) times
its own), all searched at once on the cluster; ``1 / p0 - 1`` rounds make a level.  Every candidate is a realisation
(``OUT/cases/realisation_<i>/``), accepted or not, numbered in the order they are made, so the points
depend only on the seed and the FOS before them: a stopped study makes the same points again and reads
their runs back.  A point's FOS for the levels is its search's (a FOS above ``srf_max``: infinite, never
below a threshold; below ``srf_min``: the bracket's top).  ``realisations`` bounds the searches.

A candidate's FOS matters only below its level's threshold b_k (accepted, it is ranked for the next
threshold; rejected, the chain repeats its state and its FOS is never used), so its search has b_k
as its ``srf_max`` (on the 1e-4 grid of the SRF values, rounded up: :func:`threshold_srf`) and runs it
first, alone (``fos.search``, step 6): stable there, the candidate is rejected after that one run
(its FOS above ``srf_max``: infinite, as before); failed there, the search goes on below b_k to the FOS,
in a window predicted as any point's, below the failed b_k.  The run at b_k is judged by the verdict
that makes the lowest failed run the top of every search's bracket, so a candidate is rejected exactly
when its full search would have bracketed its FOS above b_k, but for a FOS within the search's
tolerance of b_k (the knee's bracket and the verdicts' agree within it).

An accepted candidate's FOS matters only if it is among its level's ``N p0 + 1`` lowest (the next
threshold, the seeds) or below ``factor (1 + e)`` (pf and its discretisation estimate).  So a level's
candidates have a guard g below b_k, on the grid, rounded up: the seeds' FOS at the quantile q of
:func:`workflows.probabilistic.subset.guard_quantile` (about a share q of the level lies below it, q kept
above p0 by 2.5 standard errors of that share), at least ``factor (1 + e)``.  A candidate failed at b_k
runs g next, alone (``fos.search``, step 6): stable there, it is accepted after two runs, its FOS known
only to lie between g and b_k; failed, it is searched below g.  Should fewer than ``N p0 + 1`` of a level's
samples lie below its guard (its FOS law's quantile missed), the candidates between are made again as new
points (the same standard normals and fields) and searched below their b_k: the next threshold is then
the full searches' again.

Level 0 needs the same only: its ``N p0 + 1`` lowest FOS exactly (the threshold, the seeds), every other
point only as above them.  It is two rounds.  The first searches in full the ``M = LEVEL0_FIRST_SHARE
(N p0 + 1)`` points of lowest predicted FOS (each one's limit-equilibrium estimate, ``fos.prediction``:
through its own fields with random fields); the ``N p0 + 1``-th lowest of their FOS, c, is at least the
level's own (M of the N points hold ``N p0 + 1`` below it).  The second runs every other point's
``srf_max`` first at ``max(c, factor (1 + e))`` (on the grid, rounded up; e the expected discretisation
excess, 0 where none is known), as a candidate's: stable there, its FOS lies above the ``N p0 + 1``
lowest and above what pf counts (one run); failed, it is searched below.  The prediction decides only
the cost: a point it ranks too high is searched in the second round.  Level 0's FOS are then known exactly
below that top only (:func:`workflows.probabilistic.subset.pf_below`), so a subset study gives no moment
indices of the FOS (a ``monte_carlo`` study does).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.cases import Report
from workflows.distributions import DISTRIBUTIONS
from workflows.probabilistic import subset
from workflows.probabilistic.design_points import DesignPointOutcome, DesignPoints, DesignPointStudy
from workflows.probabilistic.reliability import reliability_index
from workflows.probabilistic.study_type import FIRST_REALISATIONS
from workflows.study import Study
from workflows.sweep.results import ABOVE, BELOW, NO_KNEE, case_result, diverged_result

MAX_LEVELS = 12
"""Levels at most (p0^12 = 1e-12 at p0 = 0.1)."""
SRF_GRID = 1e-4
"""SRF values lie on this grid (``fos.search``)."""
LEVEL0_FIRST_SHARE = 2.0
"""Level 0's first round searches this many times ``N p0 + 1`` points in full (module doc): c is then about the
median of their FOS, robust to a few the prediction ranks too low."""


def threshold_srf(threshold: float) -> float:
    """b_k rounded up onto the SRF grid: a candidate stable there has a FOS above b_k (module doc)."""
    return round(math.ceil(round(threshold / SRF_GRID, 6)) * SRF_GRID, 4)


@dataclass
class SubsetOutcome(DesignPointOutcome):
    """What a subset simulation found (module doc)."""

    cov: float = math.nan  # the estimator's coefficient of variation
    discretised: tuple | None = None  # (low excess, high excess, pf at h -> 0 for each) (module doc)
    thresholds: list = dataclasses.field(default_factory=list)  # b_k of each level but the last
    level_covs: list = dataclasses.field(default_factory=list)
    accepted_share: float = math.nan  # of the chains' candidates
    threshold_verdicts: int = 0  # candidates rejected by their one run at their level's threshold (module doc)
    level0_verdicts: int = 0  # level 0's points of its second round stable at its top, after one run (module doc)
    level0_searched: int = 0  # level 0's points searched in full (its first round)
    guard_verdicts: int = 0  # candidates accepted after two runs, stable at their guard (module doc)
    guard_copies: int = 0  # candidates between their guard and the threshold searched again as new points

    @property
    def verdict(self) -> str:
        if not math.isfinite(self.pf):
            return f"subset simulation: no pf ({self.stop_reason})"
        return (f"pf = {self.pf:.4g} by subset simulation (coefficient of variation {self.cov:.3g}, approximate 95% "
                f"interval [{self.pf_low:.3g}, {self.pf_high:.3g}]) after {len(self.thresholds) + 1} levels"
                + ("" if not self.stop_reason else f", STOPPED: {self.stop_reason}"))


class SubsetStudy(DesignPointStudy):
    """A study with ``[probabilistic]`` and ``method = "subset_simulation"`` (module doc)."""

    outcome_type = SubsetOutcome

    def __init__(self, study: Study, out_dir):
        super().__init__(study, out_dir)
        self.level_fos: dict[int, float] = {}  # point -> its FOS for the levels
        self.level_of: dict[int, int] = {}  # point -> the level that made it
        self.accepted: set[int] = set()  # points that are a level's sample (level 0's, and accepted candidates)
        self.levels: list[dict] = []  # each finished level: its samples' FOS, threshold, fraction, gamma
        self.chains: list[list[int]] = []  # the current level's chains: their states (point numbers)
        self.threshold = math.nan
        self.threshold_verdicts = 0  # candidates rejected by their one run at the threshold (module doc)
        self.level0_order: list[int] = []  # level 0's points, lowest predicted FOS first (module doc)
        self.level0_first = 0  # how many of them its first round searches in full
        self.level0_top = math.inf  # its second round's srf_max: level 0's FOS are known exactly below it
        self.level0_verdicts = 0  # its second round's points stable at level0_top
        self.round_points: list[int] = []  # the points of the round under way
        self.guard = math.inf  # the current level's candidates' guard (module doc; inf: none)
        self.guards: dict[int, float] = {}  # candidate -> its guard
        self.between: set[int] = set()  # candidates stable at their guard: FOS between it and the threshold
        self.copy_of: dict[int, int] = {}  # a point searched again below its guard -> the candidate it copies
        self.guard_verdicts = 0  # candidates accepted after two runs, stable at their guard

    def make_realisations(self) -> DesignPoints:
        points = DesignPoints(self.study)
        table = self.study.probabilistic
        n = len(points.marginals)
        points.add_u(np.array([np.random.default_rng(np.random.SeedSequence([table.seed, i])).standard_normal(n)
                               for i in range(table.samples_per_level)]))
        for i in range(table.samples_per_level):
            self.level_of[i] = 0
            self.accepted.add(i)
        return points

    def first_round_end(self) -> int:
        """Level 0's first round (module doc): its points ordered by their predicted FOS, the first M handed out."""
        table = self.study.probabilistic
        n = table.samples_per_level
        predicted = np.array([self._predicted_fos(i) for i in range(n)])
        self.level0_order = [int(i) for i in np.argsort(np.where(np.isfinite(predicted), predicted, np.inf),
                                                        kind="stable")]
        self.level0_first = min(n, math.ceil(LEVEL0_FIRST_SHARE * (round(table.p0 * n) + 1)))
        self.round_points = self.level0_order[:self.level0_first]
        return self.level0_first

    def _predicted_fos(self, i: int) -> float:
        """Point i's limit-equilibrium estimate (through its fields with random fields; NaN: none)."""
        study = self.realisations.study_of(i, text=False)
        estimate = self._field_estimate(study)
        return self.generation_windows[1].limit_equilibrium(study) if estimate is None else estimate

    def realisation_at(self, position: int) -> int:
        """Level 0's points in :attr:`level0_order`, the chains' candidates in their own order."""
        return self.level0_order[position] if position < len(self.level0_order) else position

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        super().case_concluded(case_id, outcome, progress)
        progress.tally(f"{self.n_concluded} FOS searches, level {len(self.levels)}")

    def _read_round(self, outcomes: dict) -> None:
        points = self.realisations
        for i in self.round_points:
            outcome = outcomes[points.case_id(i)]
            result = diverged_result("", 0) if outcome.diverged else case_result(outcome.result)
            if math.isfinite(result.fos):
                self.level_fos[i] = result.fos
            elif result.status == BELOW and math.isfinite(result.fos_high):
                self.level_fos[i] = result.fos_high
            elif i in self.guards and result.status == NO_KNEE and result.fos_low >= self.guards[i]:
                self.level_fos[i] = self.guards[i]  # stable at its guard, failed at its top: only above the guard
                self.between.add(i)
                self.guard_verdicts += 1
            else:  # above srf_max (a candidate stable at its threshold), or no verdict: never below a threshold
                self.level_fos[i] = math.inf
            if i in points.srf_max and result.status == ABOVE:
                if self.level_of[i] > 0:
                    self.threshold_verdicts += 1
                else:
                    self.level0_verdicts += 1

    def next_cases(self, outcomes: dict, progress) -> list:
        """The next round of the chains, or the next level's first; none once a level reaches the factor
        (module doc)."""
        if self.finished:
            return []
        table = self.study.probabilistic
        self._read_round(outcomes)
        if self.copy_of and self.round_points and self.round_points[0] in self.copy_of:  # copies: their candidates' FOS
            for j in self.round_points:
                self.level_fos[self.copy_of[j]] = self.level_fos[j]
                self.between.discard(self.copy_of[j])
            samples = [state for chain in self.chains for state in chain]
        elif self.chains:  # a round of candidates: each chain moves or stays
            start = self.round_start
            for k, chain in enumerate(self.chains):
                candidate = start + k
                if self.level_fos[candidate] < self.threshold:
                    chain.append(candidate)
                    self.accepted.add(candidate)
                else:
                    chain.append(chain[-1])
            if len(self.chains[0]) < round(1.0 / table.p0):
                return self._round(progress)
            samples = [state for chain in self.chains for state in chain]
            unresolved = self._between_needed(samples)
            if unresolved:
                return self._copies(unresolved, progress)
        elif self.batch_end < table.samples_per_level:  # level 0's first round: its second (module doc)
            return self._level0_second_round(progress)
        else:
            samples = list(range(table.samples_per_level))
        self._finish_level(samples, progress)
        return [] if self.finished else self._round(progress)

    def _between_needed(self, samples: list[int]) -> list[int]:
        """The level's candidates known only to lie between their guard and the threshold, when fewer than N p0 + 1
        of its samples lie below the guard (their FOS then decides the next threshold); [] otherwise."""
        table = self.study.probabilistic
        fos = sorted(self.level_fos[i] for i in samples)
        if fos[round(table.p0 * len(samples))] < self.guard:
            return []
        return sorted({i for i in samples if i in self.between})

    def _copies(self, originals: list[int], progress) -> list:
        """Each candidate of ``originals`` made again as a new point (the same standard normals and fields) whose
        search runs its top first, as the candidate's, and goes on below it with no guard: its FOS (module doc)."""
        points = self.realisations
        if points.count + len(originals) > points.budget:
            self.stop_reason = f"the budget of {points.budget} FOS searches (realisations) is spent"
            self.finished = True
            return []
        progress.message(f"subset level {len(self.levels)}: fewer than N p0 + 1 points below the guard "
                         f"{self.guard:.4f}: the {len(originals)} above it searched again")
        start = points.count
        for k, i in enumerate(originals):
            j = start + k
            self.copy_of[j], self.level_of[j] = i, self.level_of[i]
            points.srf_max[j] = points.srf_max[i]  # (its top: failed; no guard: its FOS, above the candidate's guard)
            if self.study.random_field is not None:
                points.field_terms[j] = points.field_terms.get(i, ((i, 1.0),))
        self.round_points = list(range(start, start + len(originals)))
        points.add_u(points.u[originals])
        self.batch_end = points.count
        return self.more_cases(FIRST_REALISATIONS)

    def _level0_second_round(self, progress) -> list:
        """Level 0's points not yet searched, each with its ``srf_max`` at ``max(c, factor (1 + e))`` run first
        (module doc); c infinite (fewer than N p0 + 1 FOS found below srf_max): full searches."""
        table = self.study.probabilistic
        first = sorted(self.level_fos[i] for i in self.round_points)
        c = first[round(table.p0 * table.samples_per_level)]
        self.level0_top = max(c, self._factor_top())
        self.round_points = self.level0_order[self.level0_first:]
        if math.isfinite(self.level0_top):
            for i in self.round_points:
                self.realisations.srf_max[i] = threshold_srf(self.level0_top)
            self.first = [self.realisations.case(case.position[0]) if case.position[0] in self.realisations.srf_max
                          else case for case in self.first]  # (made by check, before their srf_max)
            progress.message(f"subset level 0: {self.level0_first} points of lowest predicted FOS searched; the other "
                             f"{len(self.round_points)} run SRF {threshold_srf(self.level0_top):.4f} first")
        self.batch_end = table.samples_per_level
        return self.more_cases(FIRST_REALISATIONS)

    def _finish_level(self, samples: list[int], progress) -> None:
        """The level's threshold and its statistics; the next level's chains from its seeds (module doc)."""
        table = self.study.probabilistic
        fos = np.array([self.level_fos[i] for i in samples])
        order, threshold, last = subset.seeds_and_threshold(fos, table.p0, table.factor)
        fraction = float(np.mean(fos < threshold))
        gamma = 0.0
        if self.chains:
            states = len(self.chains[0])
            gamma = subset.chain_gamma((fos < threshold).reshape(len(self.chains), states))
        self.levels.append({"samples": samples, "threshold": threshold, "fraction": fraction, "gamma": gamma,
                            "last": last, "known_below": self.guard if self.chains else self.level0_top})
        if last:
            self.finished = True
            return
        if len(self.levels) >= MAX_LEVELS:
            self.stop_reason, self.finished = f"{MAX_LEVELS} levels and the factor not reached", True
            return
        if not math.isfinite(threshold):  # a FOS above srf_max is only known to be above it
            stage = self.study.strength_reduction
            self.stop_reason = (f"level {len(self.levels) - 1}: more than {1.0 - table.p0:.0%} of its points have a FOS "
                                f"above srf_max = {self.realisations.srf_top:g}, so its threshold (the {table.p0:g}-quantile) lies "
                                f"above the search: raise stages.{stage.name}.srf_max")
            self.finished = True
            return
        progress.message(f"subset level {len(self.levels) - 1}: threshold FOS {threshold:.4f} (p0 = {table.p0:g})")
        self.threshold = threshold
        self.chains = [[samples[j]] for j in order]
        self.guard = self._guard([self.level_fos[samples[j]] for j in order])

    def _guard(self, seeds_fos: list) -> float:
        """The next level's candidates' guard on the SRF grid (module doc): the seeds' FOS at their
        ``subset.guard_quantile``, at least factor (1 + e); inf (none) where it reaches the threshold."""
        quantile = subset.guard_quantile(len(seeds_fos), self.study.probabilistic.p0)
        if quantile >= 1.0:
            return math.inf
        guard = threshold_srf(max(float(np.quantile(seeds_fos, quantile)), self._factor_top()))
        return guard if guard < threshold_srf(self.threshold) else math.inf

    def _factor_top(self) -> float:
        """factor (1 + e), e the expected discretisation excess, high (0 where none is known): the highest FOS pf
        and its discretisation estimate count a point below, so every point's FOS is known exactly below it."""
        from workflows.fos.discretisation import expected_excess

        expected = expected_excess(self.study)
        return self.study.probabilistic.factor * (1.0 + (0.0 if expected is None else max(expected[1], 0.0)))

    def _round(self, progress) -> list:
        """One candidate per chain, as new points (module doc); none when the budget is spent."""
        table = self.study.probabilistic
        points = self.realisations
        if points.count + len(self.chains) > points.budget:
            self.stop_reason = f"the budget of {points.budget} FOS searches (realisations) is spent"
            self.finished = True
            return []
        start = points.count
        n = len(points.marginals)
        candidates = [subset.candidate(points.u[chain[-1]], np.random.default_rng(
            np.random.SeedSequence([table.seed, start + k, 1])).standard_normal(n))
            for k, chain in enumerate(self.chains)]
        for k, chain in enumerate(self.chains):
            self.level_of[start + k] = len(self.levels)
            points.srf_max[start + k] = threshold_srf(self.threshold)  # its search runs b_k first (module doc)
            if math.isfinite(self.guard):
                self.guards[start + k] = self.guard
            if self.study.random_field is not None:  # the fields' xi moves with u (module doc)
                state = chain[-1]
                points.field_terms[start + k] = subset.moved_terms(points.field_terms.get(state, ((state, 1.0),)),
                                                                   start + k)
        self.round_start = start
        self.round_points = list(range(start, start + len(self.chains)))
        points.add_u(np.array(candidates))
        self.batch_end = points.count
        return self.more_cases(FIRST_REALISATIONS)

    def _placed(self, case):
        """A point as any realisation (``ProbabilisticStudy._placed``); a chain's candidate runs its level's
        threshold, its ``srf_max``, first (module doc)."""
        case = super()._placed(case)
        i = case.position[0]
        return (dataclasses.replace(case, top_first=True, guard=self.guards.get(i)) if i in self.realisations.srf_max
                else case)

    def _discretisation(self, result: SubsetOutcome) -> tuple | None:
        """The expected excess of every point's FOS at the study's spacing (``fos.discretisation``: the measured
        slopes near its friction angle), low and high, and pf with every FOS lowered by it: P(FOS < factor (1 +
        e)) from the deepest level that holds it (``subset.pf_below``); None where no slope was measured near."""
        from workflows.fos.discretisation import expected_excess

        table = self.study.probabilistic
        expected = expected_excess(self.study)
        if expected is None:
            return None
        low, high, _ = expected
        level_fos = [[self.level_fos[i] for i in level["samples"]] for level in self.levels]
        thresholds = [level["threshold"] for level in self.levels[:-1]]
        known = [level["known_below"] for level in self.levels]
        return low, high, *(subset.pf_below(table.p0, level_fos, thresholds, table.factor * (1.0 + e), known)
                            for e in (low, high))

    def _method_results(self, result: SubsetOutcome, ds, attrs: dict):  # type: ignore[override]
        from workflows.output.variables import PROBABILISTIC_FILE as var

        table = self.study.probabilistic
        levels = self.levels
        result.stop_reason = self.stop_reason
        n = table.samples_per_level
        if levels and levels[-1]["last"]:
            covs = [subset.level_cov(level["fraction"], n, level["gamma"]) for level in levels]
            result.pf = subset.estimate(table.p0, levels[-1]["fraction"], len(levels))
            result.cov = math.sqrt(sum(c * c for c in covs))
            result.pf_low, result.pf_high = subset.interval(result.pf, result.cov)
            result.level_covs = covs
            result.discretised = self._discretisation(result)
        result.thresholds = [level["threshold"] for level in levels if not level["last"]]
        chained = [i for i in self.level_of if self.level_of[i] > 0 and i not in self.copy_of]
        result.accepted_share = (sum(i in self.accepted for i in chained) / len(chained)) if chained else math.nan
        result.threshold_verdicts = self.threshold_verdicts
        result.level0_verdicts, result.level0_searched = self.level0_verdicts, min(self.level0_first, len(self.level_fos))
        result.guard_verdicts, result.guard_copies = self.guard_verdicts, len(self.copy_of)
        first = np.array([self.level_fos[i] for i in range(n) if i in self.level_fos and math.isfinite(self.level_fos[i])])
        if first.size >= 3 and not math.isfinite(self.level0_top):  # every FOS of level 0 known: its moment indices
            result.fos_mean, result.fos_std = float(first.mean()), float(first.std(ddof=1))
            attrs.update(fos_mean=result.fos_mean, fos_std=result.fos_std,
                         reliability_index_normal=reliability_index(first, DISTRIBUTIONS["normal"]),
                         reliability_index_lognormal=reliability_index(first, DISTRIBUTIONS["lognormal"]))
        count = ds.sizes["realisation"]
        ds["subset_level"] = var["subset_level"](np.array([self.level_of.get(i, -1) for i in range(count)]))
        ds["subset_accepted"] = var["subset_accepted"](np.array([int(i in self.accepted) for i in range(count)],
                                                                dtype=np.int8))
        last = levels[-1]["samples"] if levels else []
        ds["last_level_failed"] = var["last_level_failed"](np.array(
            [int(i in set(last) and self.level_fos.get(i, math.inf) < table.factor) for i in range(count)], dtype=np.int8))
        thresholds = result.thresholds + ([table.factor] if levels and levels[-1]["last"] else [])
        probabilities = [table.p0 ** (k + 1) for k in range(len(result.thresholds))]
        if levels and levels[-1]["last"]:
            probabilities.append(result.pf)
        ds = ds.assign_coords(subset_threshold=("subset_threshold", np.arange(len(thresholds)),
                                                {"long_name": "level"}))
        ds["threshold_fos"] = var["threshold_fos"](np.array(thresholds, float))
        ds["threshold_pf"] = var["threshold_pf"](np.array(probabilities, float))
        if result.discretised is not None:
            attrs.update(pf_discretisation_excess=f"{result.discretised[0]:.4f} {result.discretised[1]:.4f}",
                         pf_at_zero_spacing=f"{result.discretised[2]:.4g} {result.discretised[3]:.4g}")
        attrs.update(pf=result.pf, pf_low=result.pf_low, pf_high=result.pf_high, pf_cov=result.cov,
                     p0=table.p0, samples_per_level=n, subset_levels=len(levels),
                     subset_accepted_share=result.accepted_share, subset_threshold_verdicts=result.threshold_verdicts,
                     subset_level0_searched=result.level0_searched, subset_level0_verdicts=result.level0_verdicts,
                     subset_guard_verdicts=result.guard_verdicts, subset_guard_copies=result.guard_copies,
                     subset_stop_reason=result.stop_reason)
        return ds

    def _figure(self, ds) -> Path:
        from workflows.probabilistic.design_point_figures import draw_subset_simulation  # matplotlib: on use

        return draw_subset_simulation(self.out_dir, ds, self.study.probabilistic.factor)

    def report(self, outcome: SubsetOutcome, quiet: bool, study_file) -> Report:  # type: ignore[override]
        report = super().report(outcome, quiet, study_file)
        if quiet or not math.isfinite(outcome.pf):
            return report
        table = self.study.probabilistic
        levels = ", ".join(f"FOS < {b:.4f}: {table.p0 ** (k + 1):.3g}" for k, b in enumerate(outcome.thresholds))
        crude = (1.0 - outcome.pf) / (outcome.pf * outcome.cov**2) if outcome.pf > 0.0 else math.inf
        report.lines[1:1] = [
            f"levels ({table.samples_per_level} points each, p0 = {table.p0:g}): {levels or '-'}; the level "
            f"covs {', '.join(f'{c:.3g}' for c in outcome.level_covs)} (with the chains' correlation)"
            + (f"; {100 * outcome.accepted_share:.0f}% of the chains' candidates accepted"
               if math.isfinite(outcome.accepted_share) else ""),
            _discretisation_line(outcome),
            f"crude Monte Carlo would need about {crude:,.0f} realisations for this pf at this coefficient of "
            f"variation, (1 - pf) / (pf cov^2); subset simulation made {outcome.n_searches} FOS searches: level 0 "
            f"searched {outcome.level0_searched} of its points of lowest predicted FOS in full and ran the others' "
            f"top first ({outcome.level0_verdicts} stable there after one run); {outcome.threshold_verdicts} chains' "
            f"candidates rejected by their one run at their level's threshold, {outcome.guard_verdicts} accepted after "
            f"two (stable at their guard)" + (f", {outcome.guard_copies} searched again below their threshold (fewer "
                                              "than N p0 + 1 below a guard)" if outcome.guard_copies else "")]
        return report


def _discretisation_line(outcome) -> str:
    """pf's discretisation estimate, apart from its sampling interval (``SubsetStudy._discretisation``)."""
    if outcome.discretised is None:
        return ("discretisation: no estimate of pf at h -> 0 (no slope measured near this friction angle); see the "
                "note below")
    low, high, pf_low, pf_high = outcome.discretised
    return (f"discretisation (apart from the sampling interval): every FOS expected {100 * low:.1f}% to "
            f"{100 * high:.1f}% above its value at h -> 0, so pf at h -> 0 about {pf_low:.3g} to {pf_high:.3g} "
            "(P(FOS < factor (1 + excess)) from the levels' samples)")
