"""Which strength-reduction runs to make, and in what order.

The search knows nothing of dask or files: it is told which runs finished with which
maximum displacement and verdict, and says which SRF values to start next.

1. **Sweep**: ``srf_min, srf_min + srf_step, ... <= srf_max``, and ``srf_max``, in ascending
   order.  Once a run has failed, sweep values above it are not started (they cannot move the knee, which
   lies before the first failure); they are listed in :attr:`SrfSearch.skipped`.  With a **window**
   (``low, high, step`` about a predicted FOS, ``workflows.fos.prediction``) the sweep is the window's
   values instead, within [srf_min, srf_max]; when its runs give no knee (the prediction missed), it
   grows on the side where the FOS lies, above the window when none of its runs failed, below it when
   one did and no run below that failure is stable (with one, the denser sweep of step 2 gives the knee
   its runs), or when there is no upturn: first by one value twice the window's step beyond that end
   (the window's step doubled: a near miss costs one run), and if that misses too, the stage's full
   sweep joins beyond it (its values more than a step beyond).  A window that misses by far costs its own few runs and that one value
   besides what the full sweep would have run.  The knee and the bracket are then found as without a
   window.
2. **Refinement**: when the sweep is done (made denser between its last stable run and its first
   failure while it has fewer than ``MIN_KNEE_RUNS`` runs up to that failure), the FOS bracket (the steepest rise after the
   knee, see :mod:`workflows.fos.criterion`) is split by at most ``REFINE_SPLIT`` equally
   spaced runs, as many as keep the total at what bisection would need to bring it under
   ``tolerance`` (:func:`~workflows.fos.criterion.refinement_points`); the bracket is picked
   again from all runs and the step repeats until it is within the tolerance, there is no
   knee, or ``max_runs`` runs have been made.
3. **Speculation** (:meth:`SrfSearch.speculative_values`): while the search waits for its
   one undecided run and a worker is idle, it names the values it would ask for next under
   either outcome of that run.  A caller may start them; it must keep their results out of
   the answer until :meth:`SrfSearch.next_values` asks for the same value, so the runs used
   and the FOS stay those of the plan above, whatever the number of workers.
4. **Predicted failure** (:meth:`SrfSearch.predicted_failure`): before any run has failed,
   a pending sweep run whose displacement, extrapolated log-linearly from the two finished
   sweep runs below it, reaches ``failure_m`` is expected to fail.  Sweep values above it
   are held back until it finishes (they would be cancelled if it fails), and an idle worker
   speculates on its outcome instead, failed branch first.
5. **Failure known early** (:meth:`SrfSearch.passed_failure`): a pending run whose largest
   displacement has passed ``failure_m`` will end failed (the displacement only grows), or
   diverged.  It is then expected to fail for certain, sweep run or not: values above it are
   held back, runs above it that were started are stopped (:meth:`SrfSearch.deferred`: asked
   for again only if it diverges), and an idle worker speculates on its failed branch alone.
   None of this changes the runs used or the FOS: it only frees workers sooner.
6. **The top first** (``top_first``, a chain candidate of subset simulation, whose ``srf_max`` is its
   level's threshold): the run at ``srf_max`` is made first, alone.  Stable there, the search ends
   (status above ``srf_max``: one run, the FOS above the threshold); failed (or known to fail, step 5)
   or diverged, the search goes on below it as above, the top one of its sweep values (as the full
   sweep's ``srf_max`` always is), so its FOS lies below the failed top.  The verdict at the top is the
   verdict that brackets every search (the lowest failed run is the top of the FOS bracket).  With a
   ``guard`` below the top (subset simulation: a value below which the candidate's FOS matters), the
   guard is run next, alone, once the top has failed: stable there, the search ends with no FOS (the
   FOS lies between the guard and the top, the verdicts' bracket); failed, it goes on below the guard.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from itertools import chain, zip_longest

from workflows.fos.criterion import FosPick, pick_fos, refinement_points
from workflows.fos.verdict import DIVERGED, FAILED, STABLE

CANCELLED_ABOVE_FAILURE = "cancelled: above the failed SRF {:g}, cannot move the knee"
"""Why a started run was stopped once a run below it had failed."""

STABLE_AT_TOP = "stable at srf_max {:g}, run first: the FOS lies above it"
STABLE_AT_GUARD = "stable at SRF {:g} and failed at srf_max {:g}, run first: the FOS lies between them"
"""Why a search with a guard ended after its top and its guard (module doc, step 6)."""
"""Why a search whose top was run first (module doc, step 6) ended after it."""

MIN_KNEE_RUNS = 3
"""Runs up to the first failure that the knee needs (``criterion.pick_knee``): a sweep with fewer is
made denser (step 2)."""

REFINE_SPLIT = 2
"""At most this many runs per refinement round (see ``refinement_points``: never more runs in
total than bisection).  Fixed, not the worker count, so that the runs made, and the FOS, do
not depend on how many workers there are."""


@dataclass(frozen=True)
class RunOutcome:
    """What the search needs from one finished run."""

    srf: float
    max_displacement_m: float
    status: str  # verdict.STABLE / FAILED / DIVERGED


def sweep_values(srf_min: float, srf_max: float, srf_step: float) -> list[float]:
    """srf_min, srf_min + step, ... up to srf_max (inclusive within 1e-9), then srf_max itself when
    the step does not land on it (srf_min 1, step 0.3, srf_max 2: 1, 1.3, 1.6, 1.9, 2), rounded to
    1e-4: the sweep always reaches the srf_max the study asks for."""
    n = int(math.floor((srf_max - srf_min) / srf_step + 1e-9))
    return sorted({round(srf_min + i * srf_step, 4) for i in range(n + 1)} | {round(srf_max, 4)})


class SrfSearch:
    """The sweep-then-refine plan (module doc)."""

    def __init__(self, srf_min, srf_max, srf_step, tolerance, floor_m, n_parallel=2, max_runs=40,
                 failure_m=math.inf, window: tuple[float, float, float] | None = None, top_first: bool = False,
                 guard: float | None = None):
        self.range = (round(float(srf_min), 4), round(float(srf_max), 4))
        self.full_step = round(float(srf_step), 4)
        self.grown = 0  # how far the window has grown: 1 by its neighbour, 2 by the full sweep (module doc, step 1)
        self.window = None
        if window is not None:
            low, high, step = window
            step = max(round(step, 4), 1e-4)
            low = min(max(round(low, 4), self.range[0]), self.range[1])  # both ends within [srf_min, srf_max]
            high = max(min(round(high, 4), self.range[1]), self.range[0])
            if high - low < step:  # a window at (or beyond) an end of the range: a step inside it
                low, high = (max(high - step, self.range[0]), high) if high >= self.range[1] else (low, min(low + step, self.range[1]))
            self.window = (low, max(high, low), step)
            self.sweep = sweep_values(*self.window)
        else:
            self.sweep = sweep_values(srf_min, srf_max, srf_step)
        self.top_first = top_first  # module doc, step 6
        self.guard = (round(float(guard), 4) if top_first and guard is not None and self.range[0] <= guard < self.range[1]
                      else None)
        if top_first:
            self.sweep = sorted(set(self.sweep) | {self.range[1]} | ({self.guard} if self.guard is not None else set()))
        self.sweep_set = set(self.sweep)
        self.tolerance = float(tolerance)
        self.floor_m = float(floor_m)
        self.failure_m = float(failure_m)  # a run past this displacement fails (module doc, step 4)
        self.n_parallel = max(1, int(n_parallel))
        self.max_runs = int(max_runs)
        self.outcomes: dict[float, RunOutcome] = {}
        self.pending: set[float] = set()
        self.failing: set[float] = set()  # pending runs past failure_m (module doc, step 5)
        self.deferred_by: dict[float, float] = {}  # started runs stopped above a failing one -> that run
        self.skipped: dict[float, str] = {}
        self.stop_reason = ""

    # ------------------------------------------------------------------ bookkeeping
    def started(self, srf: float) -> None:
        self.pending.add(srf)

    def above_failure(self, srf: float) -> bool:
        """Whether a started value ``srf`` can no longer move the knee: above the lowest failed run, or
        above a run known to fail (step 5).  A query: :meth:`withdraw` acts on it."""
        return srf > self.lowest_failed or srf > self.certain_failure()

    def withdraw(self, srf: float) -> None:
        """The asked-for run ``srf`` above a failure (:meth:`above_failure`) is stopped: skipped when a
        run below it failed, deferred when one below it will (step 5)."""
        failed = self.lowest_failed
        if srf > failed:
            self.pending.discard(srf)
            self.skipped[srf] = CANCELLED_ABOVE_FAILURE.format(failed)
        else:
            self.deferred(srf)

    def finished(self, outcome: RunOutcome) -> None:
        self.pending.discard(outcome.srf)
        self.failing.discard(outcome.srf)
        self.outcomes[outcome.srf] = outcome
        for srf, cause in list(self.deferred_by.items()):
            if cause == outcome.srf:
                del self.deferred_by[srf]
                if outcome.status == FAILED and srf not in self.sweep_set:  # (sweep values: next_values says)
                    self.skipped[srf] = CANCELLED_ABOVE_FAILURE.format(cause)

    def passed_failure(self, srf: float) -> None:
        """The pending run ``srf`` has moved more than ``failure_m``: it will fail (module doc, step 5)."""
        if srf in self.pending:
            self.failing.add(srf)

    def certain_failure(self) -> float:
        """The lowest pending run known to fail (:meth:`passed_failure`); inf if none."""
        return min(self.failing, default=math.inf)

    def deferred(self, srf: float) -> None:
        """The started run ``srf`` was stopped because a run below it will fail: neither finished
        nor skipped, so the search asks for it again if that run diverges instead."""
        self.pending.discard(srf)
        self.deferred_by[srf] = self.certain_failure()

    @property
    def lowest_failed(self) -> float:
        failed = [o.srf for o in self.outcomes.values() if o.status == FAILED]
        return min(failed) if failed else math.inf

    def predicted_failure(self) -> float:
        """The lowest pending SRF expected to fail: one known to (:meth:`certain_failure`, step 5),
        or, before any run has failed, a sweep SRF extrapolated to (step 4); inf if none.  From
        the two finished sweep runs F1 < F2 below a pending sweep F,

            u(F) = u2 (u2 / u1)^((F - F2) / (F2 - F1))  >=  failure_m.
        """
        return min(self.certain_failure(), self._extrapolated_failure())

    def _extrapolated_failure(self) -> float:
        """Step 4 of the module doc (inf once a run has failed)."""
        if not math.isfinite(self.failure_m) or math.isfinite(self.lowest_failed):
            return math.inf
        finished = sorted((o.srf, o.max_displacement_m) for o in self.outcomes.values()
                          if o.srf in self.sweep_set and o.status == STABLE)
        for srf in sorted(f for f in self.pending if f in self.sweep_set):
            below = [(f, u) for f, u in finished if f < srf]
            if len(below) < 2:
                continue
            (f1, u1), (f2, u2) = below[-2:]
            if not (u1 > 0.0 and u2 > 0.0 and u2 > u1):
                continue
            if u2 * (u2 / u1) ** ((srf - f2) / (f2 - f1)) >= self.failure_m:
                return srf
        return math.inf

    @property
    def between_top_and_guard(self) -> bool:
        """Stable at the guard, its top run first (step 6): the FOS lies between them, no FOS sought."""
        guard = self.outcomes.get(self.guard) if self.guard is not None else None
        return guard is not None and guard.status == STABLE

    def knee(self) -> FosPick:
        """The FOS from the runs made so far (diverged runs left out): the knee of the sweep
        runs, then the largest rise after it among all runs; none between the guard and the top (step 6)."""
        if self.between_top_and_guard:
            return FosPick(math.nan, self.guard, self.range[1], math.nan,
                           STABLE_AT_GUARD.format(self.guard, self.range[1]))
        usable = sorted((o for o in self.outcomes.values() if o.status != DIVERGED), key=lambda o: o.srf)
        # the sweep up to its first failure: runs above it (started before that failure was known)
        # depend on timing and must not change the answer
        failed = [o.srf for o in usable if o.srf in self.sweep_set and o.status == FAILED]
        ceiling = min(failed) if failed else math.inf
        sweep = [o for o in usable if o.srf in self.sweep_set and o.srf <= ceiling]
        return pick_fos(
            [o.srf for o in sweep], [o.max_displacement_m for o in sweep],
            [o.srf for o in usable], [o.max_displacement_m for o in usable], [o.status for o in usable],
            self.floor_m,
        )

    # ------------------------------------------------------------------ planning
    def next_values(self) -> list[float]:
        """SRF values to start now (may be empty while runs are pending); [] and ``done`` at the end."""
        top = self.range[1]
        if self.top_first and top not in self.failing:  # step 6: the top alone, first
            if top in self.pending:
                return []
            if top not in self.outcomes:
                return [top]
            if self.outcomes[top].status == STABLE:
                self.stop_reason = STABLE_AT_TOP.format(top)
                return []
        guard = self.guard
        if guard is not None and guard not in self.failing:  # step 6: the top has failed (or will): the guard alone
            if guard in self.pending:
                return []
            if guard not in self.outcomes:
                return [guard]
            if self.between_top_and_guard:
                self.stop_reason = STABLE_AT_GUARD.format(guard, top)
                return []
        if len(self.outcomes) + len(self.pending) >= self.max_runs:
            if not self.pending and not self.stop_reason:
                self.stop_reason = f"stopped at max_runs = {self.max_runs} before the bracket reached the tolerance"
            return []
        ceiling = self.lowest_failed
        todo = [f for f in self.sweep if f not in self.outcomes and f not in self.pending and f not in self.skipped]
        for f in todo:
            if f > ceiling:
                self.skipped[f] = f"above the failed SRF {ceiling:g}: cannot move the knee"
        todo = [f for f in todo if f <= min(ceiling, self.predicted_failure())]  # step 4: held back
        if todo:
            free = self.n_parallel - len(self.pending)
            room = self.max_runs - len(self.outcomes) - len(self.pending)
            return todo[: max(0, min(free, room))]
        if any(f <= ceiling for f in self.pending):
            return []  # the refinement needs the sweep (or the last batch) below the first failure

        knee = self.knee()
        if math.isnan(knee.fos):
            grown = self._grown_window()
            if grown:
                return grown[: max(0, min(self.n_parallel, self.max_runs - len(self.outcomes)))]
            denser = self._denser_sweep()
            if denser:
                return denser[: max(0, self.max_runs - len(self.outcomes))]
            self.stop_reason = knee.reason
            return []
        room = self.max_runs - len(self.outcomes)
        points = [
            f for f in refinement_points(knee.fos_low, knee.fos_high, self.tolerance, REFINE_SPLIT)
            if f not in self.outcomes
        ][:room]
        if not points:
            if not self.stop_reason:
                self.stop_reason = (
                    f"bracket [{knee.fos_low:g}, {knee.fos_high:g}] within the tolerance {self.tolerance:g}"
                    if knee.fos_high - knee.fos_low <= self.tolerance + 1e-9
                    else f"bracket [{knee.fos_low:g}, {knee.fos_high:g}] cannot be split further on the 1e-4 grid"
                )
            return []
        return points

    def _grown_window(self) -> list[float]:
        """The window's miss (module doc, step 1): the value twice the window's step beyond its end on the
        side where the FOS lies, then the stage's full sweep more than a step beyond that (a value of it
        closer to the end would make a pair of runs whose tiny difference of SRF gives the steepest rise of
        the displacement, and the FOS, wherever the curve merely bends).  [] without a window, once the
        full sweep has joined, while the denser sweep can give the knee its runs (:meth:`_denser_points`),
        or when no value is left on that side."""
        if self.window is None or self.grown >= 2:
            return []
        ceiling = self.lowest_failed
        upwards = math.isinf(ceiling)
        if not upwards and self._denser_points():
            return []
        _, _, step = self.window
        if self.grown == 0:
            self.grown = 1
            end = max(self.sweep) if upwards else min(self.sweep)
            neighbour = round(min(end + 2 * step, self.range[1]) if upwards else max(end - 2 * step, self.range[0]), 4)
            if neighbour not in self.outcomes and neighbour not in self.sweep_set:
                return self._join([neighbour])
        self.grown = 2
        end = max(self.sweep) if upwards else min(self.sweep)
        full = sweep_values(self.range[0], self.range[1], self.full_step)
        return self._join([f for f in full if (f > end + step if upwards else f < end - step)
                           and f not in self.outcomes and f not in self.sweep_set])

    def _join(self, values: list[float]) -> list[float]:
        """``values`` join the sweep; those at or below the lowest failure, to run."""
        self.sweep = sorted(self.sweep_set | set(values))
        self.sweep_set = set(self.sweep)
        return [f for f in values if f <= self.lowest_failed]

    def _denser_points(self) -> list[float]:
        """Where a sweep too coarse for a knee is made denser (:meth:`_denser_sweep`): fewer than
        ``MIN_KNEE_RUNS`` runs up to its first failure, split between its last stable run and that failure
        while they lie more than the tolerance apart; [] otherwise."""
        ceiling = self.lowest_failed
        sweep = [o for o in self.outcomes.values() if o.srf in self.sweep_set and o.srf <= ceiling and o.status != DIVERGED]
        stable = [o.srf for o in sweep if o.status == STABLE and o.srf < ceiling]
        if len(sweep) >= MIN_KNEE_RUNS or not stable or not math.isfinite(ceiling):
            return []
        return [f for f in refinement_points(max(stable), ceiling, self.tolerance, REFINE_SPLIT) if f not in self.outcomes]

    def _denser_sweep(self) -> list[float]:
        """A sweep too coarse for a knee (fewer than ``MIN_KNEE_RUNS`` runs up to its first failure,
        e.g. stable at 1.0 and failed at 1.5) is made denser between its last stable run and that
        failure (step 2's split): the new values join the sweep.  [] when the sweep has enough runs,
        no stable run below a failure to split from, or one within the tolerance of it."""
        points = self._denser_points()
        self.sweep = sorted(set(self.sweep) | set(points))
        self.sweep_set = set(self.sweep)
        return points

    def speculative_values(self, n_free: int) -> list[float]:
        """Up to ``n_free`` values that :meth:`next_values` would ask for once the one run it
        waits for has finished, for otherwise idle workers (module doc, step 3).

        Only when exactly one run below the first failure is pending (the end of the sweep, a
        refinement round of one run, or the last run of a round), and before any failure only
        when that run is expected to fail (:meth:`predicted_failure`).  Its two outcomes are
        imagined: failed with the displacement of the lowest failed run (``failure_m`` before
        any), and stable with the displacement of the run below it; the values each branch
        would start are interleaved, failed branch first.  A run known to fail
        (:meth:`passed_failure`) has its failed branch only.  That branch puts the bracket in the
        lower part of the split, where it went in every strength-reduction study we ran: above
        the knee log u rises fastest first.
        """
        if n_free <= 0 or self.stop_reason:
            return []
        ceiling = self.lowest_failed
        undecided = [f for f in self.pending if f <= ceiling]
        usable = sorted((o for o in self.outcomes.values() if o.status != DIVERGED), key=lambda o: o.srf)
        if len(undecided) != 1:
            return []
        [srf] = undecided
        if math.isfinite(ceiling):
            failed_u = self.outcomes[ceiling].max_displacement_m
        elif self.predicted_failure() == srf:
            failed_u = self.failure_m
        else:
            return []
        below = [o for o in usable if o.srf < srf]
        if not below:
            return []
        outcomes = [RunOutcome(srf, failed_u, FAILED)]
        if srf not in self.failing:
            outcomes.append(RunOutcome(srf, below[-1].max_displacement_m, STABLE))
        branches = []
        for outcome in outcomes:
            branch = copy.deepcopy(self)
            branch.finished(outcome)
            branches.append([f for f in branch.next_values() if f not in self.outcomes and f not in self.pending])
        values: list[float] = []
        for f in chain.from_iterable(zip_longest(*branches)):
            if f is not None and f not in values:
                values.append(f)
        return values[:n_free]
