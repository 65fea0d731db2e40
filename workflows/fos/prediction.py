"""Where a case's FOS is expected, from the cases of its study already concluded: the window its
search starts in (``fos.search``: a sweep of a few runs about the prediction, grown when it misses).

A case's limit-equilibrium estimate E_i (Bishop's least circle on a coarse raster of its section,
``fos.critical_circle.critical_circle(quick=True)``, a fraction of a second) carries what the case
changes: its strength, its geometry, its water.  The strength reduction's FOS F_i differs from it by
a ratio that varies slowly over a study (the method's discretisation excess, the circle's own, a
non-circular mechanism), so

    F_i ~ E_i r(x_i),      r(x) = b0 + b . x     (least squares over the concluded cases)

with x_i the case's own numbers (a sweep's axis values, a realisation's random variables; a
friction angle as tan(phi)), standardised.  With fewer concluded cases than the fit needs, r is their
mean ratio (one case: its own), or 1 with none.  The expected error sigma (of F, one standard
deviation) is the fit's residual scatter times E_i, floored at ``MIN_SIGMA``, or ``NO_CASE_SIGMA``
(``ONE_CASE_SIGMA``) of E_i with no (one) concluded case.

The window: ``WINDOW_BELOW`` step d below F_i and ``WINDOW_ABOVE`` steps above it, d the least
tolerance x 2^k (k = 0, 1, ...) at least ``SIGMA_PER_STEP`` sigma (:func:`search_window`): the window
leaves a bracket of one step, which bisection brings to the tolerance in k runs, as it would any step
above tolerance x 2^(k-1), so the wider step costs no more runs and misses less.  Its values run upwards and stop at the first
failure, so a value above the FOS costs nothing and each one below it a run: one below gives the knee
its third run when the prediction holds (the run below F_i, the one at it, the first above).  A case whose
search runs its ``srf_max`` first (``fos.search``, step 6: a chain candidate of subset simulation) searches
on only once that run has failed, so its FOS lies below ``srf_max``: a prediction above it is taken as
``srf_max``, and its window is moved down to end there (at its guard, with one: the search goes on only
below a failed guard).  A window that misses grows (``SrfSearch``: a near miss by one value at twice its step), so a poor
prediction costs runs, never the answer: the knee and the bracket are found as without a window.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

NO_CASE_SIGMA = 0.06
"""The expected error of limit equilibrium alone, a fraction of its F: the strength reduction's FOS at a
coarse spacing lies a few per cent above it, a non-circular mechanism's below it."""
ONE_CASE_SIGMA = 0.03
"""... of limit equilibrium times one case's ratio."""
MIN_SIGMA = 0.004
"""The least expected error of a fitted ratio, a fraction of F: the cases' own search resolution and
path scatter."""
WINDOW_BELOW = 1
WINDOW_ABOVE = 3
SIGMA_PER_STEP = 1.0
TRUSTED_RATIO = (0.5, 2.0)
"""F_i / E_i of a concluded case outside this range means its limit-equilibrium estimate missed the
mechanism (e.g. no circle through a vertical face): the case joins no fit."""


@dataclass(frozen=True)
class Prediction:
    fos: float
    sigma: float  # expected error of fos (one standard deviation)
    basis: str  # how it was made, for the messages


class FosPredictor:
    """The model of the module doc over the cases concluded so far."""

    def __init__(self):
        self.features: list[np.ndarray] = []
        self.ratios: list[float] = []

    def observe(self, features, estimate: float, fos: float) -> None:
        """A concluded case: its numbers, its limit-equilibrium estimate and its FOS (NaN-free only)."""
        if (math.isfinite(estimate) and estimate > 0.0 and math.isfinite(fos) and fos > 0.0
                and TRUSTED_RATIO[0] <= fos / estimate <= TRUSTED_RATIO[1]):
            self.features.append(np.asarray(features, dtype=float).ravel())
            self.ratios.append(fos / estimate)

    def predict(self, features, estimate: float) -> Prediction | None:
        """The case's expected FOS and its error, or None without a limit-equilibrium estimate."""
        if not (math.isfinite(estimate) and estimate > 0.0):
            return None
        n = len(self.ratios)
        if n == 0:
            return Prediction(estimate, NO_CASE_SIGMA * estimate, "limit equilibrium")
        ratios = np.array(self.ratios)
        if n == 1:
            return Prediction(estimate * ratios[0], ONE_CASE_SIGMA * estimate, "limit equilibrium times one case's ratio")
        x = np.array(self.features)
        x_new = np.asarray(features, dtype=float).ravel()
        varying = np.ptp(x, axis=0) > 0.0 if x.size else np.zeros(0, dtype=bool)
        p = int(varying.sum())
        if n >= p + 2 and p > 0:  # a fit with a residual to judge it by
            mean, scale = x[:, varying].mean(axis=0), np.ptp(x[:, varying], axis=0)
            design = np.column_stack([np.ones(n), (x[:, varying] - mean) / scale])
            coefficients, *_ = np.linalg.lstsq(design, ratios, rcond=None)
            residual = ratios - design @ coefficients
            spread = math.sqrt(float(residual @ residual) / (n - p - 1)) if n > p + 1 else 0.0
            row = np.concatenate([[1.0], (x_new[varying] - mean) / scale])
            ratio = float(row @ coefficients)
            basis = f"limit equilibrium times a ratio fitted over {n} cases"
        else:
            ratio, spread = float(ratios.mean()), float(ratios.std(ddof=1))
            basis = f"limit equilibrium times the mean ratio of {n} cases"
        return Prediction(estimate * ratio, max(spread, MIN_SIGMA) * estimate, basis)


def search_window(prediction: Prediction, tolerance: float) -> tuple[float, float, float]:
    """(low, high, step) of the module doc, rounded to 1e-4."""
    halvings = max(0, math.ceil(math.log2(max(SIGMA_PER_STEP * prediction.sigma / tolerance, 1.0)) - 1e-9))
    step = round(tolerance * 2**halvings, 4)
    low = max(round(prediction.fos - WINDOW_BELOW * step, 4), 0.01)
    return low, round(low + (WINDOW_BELOW + WINDOW_ABOVE) * step, 4), step


def maximin_order(features: np.ndarray) -> list[int]:
    """The cases in an order that spreads them: first the one farthest from the mean, then each time the
    one farthest from those taken (standardised features; ties by index).  On a grid: its corners, then
    the middles of its edges, then its inside: each later case lies among earlier ones, where the fit
    interpolates."""
    x = np.asarray(features, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    if n == 0:
        return []
    scale = np.where(np.ptp(x, axis=0) > 0.0, np.ptp(x, axis=0), 1.0)
    z = (x - x.mean(axis=0)) / scale
    taken = [int(np.argmax(np.round(np.sum(z * z, axis=1), 12)))]
    nearest = np.sum((z - z[taken[0]]) ** 2, axis=1)
    while len(taken) < n:
        candidates = np.round(nearest, 12)
        candidates[taken] = -1.0
        pick = int(np.argmax(candidates))
        taken.append(pick)
        nearest = np.minimum(nearest, np.sum((z - z[pick]) ** 2, axis=1))
    return taken


class Generations:
    """How many cases a study may hand out: generations of 1, 2, 4, ... cases (at most ``largest``), the
    next once every case handed out has concluded.  The cases of a generation are predicted from
    those of the earlier ones only, so the predictions, the runs and every FOS do not depend on the
    number of workers or on which case finished first, and a resumed study predicts what the first
    invocation predicted."""

    def __init__(self, total: int, largest: int = 8):
        self.total = total
        self.largest = largest
        self.given = 0
        self.end = 0  # the current generation ends before this case
        self.size = 1
        self.concluded = 0
        self.held: list[tuple[int, object]] = []  # (case order, what it taught) of the generation under way

    def room(self, concluded: int) -> int:
        """How many more cases may be handed out now, ``concluded`` of those handed out having concluded."""
        self.concluded = concluded
        if self.given >= self.end:
            if concluded < self.given:
                return 0
            self.end = min(self.total, self.given + self.size)
            self.size = min(2 * self.size, self.largest)
        return self.end - self.given

    def take(self, count: int) -> None:
        self.given += count

    def hold(self, order: int, observation) -> None:
        """What a concluded case taught (its FOS), kept until its whole generation has
        concluded: a case handed out late in its generation is predicted from the earlier
        generations alone, as the others of it, whichever of its own generation finished first (so
        a resumed study, whose cases on disk conclude first, repeats the uninterrupted one)."""
        self.held.append((order, observation))

    def released(self, concluded: int) -> list:
        """The observations held, in case order, once every case handed out has concluded at the end
        of a generation (then forgotten here); none before."""
        if self.given < self.end or concluded < self.given:
            return []
        observations = [observation for _, observation in sorted(self.held, key=lambda held: held[0])]
        self.held = []
        return observations


class WindowPredictor:
    """The window each case's search starts in (module doc): its limit-equilibrium estimate, its
    numbers, and the cases concluded so far."""

    def __init__(self):
        self.predictor = FosPredictor()
        self.estimates: dict = {}  # what the estimate depends on -> the estimate (realisations of fields share one)
        self.pending: dict[str, tuple[np.ndarray, float]] = {}  # case id -> (its numbers, its estimate)
        self.windows: dict[str, tuple[Prediction, tuple[float, float, float]]] = {}

    def window(self, case, features, estimate: float | None = None) -> tuple[float, float, float] | None:
        """The window of ``case`` (a ``cases.Case``) with its numbers ``features`` and its limit-equilibrium
        ``estimate`` (default: its critical circle's F); None: none."""
        estimate = self.limit_equilibrium(case.study) if estimate is None else estimate
        self.pending[case.case_id] = (np.asarray(features, dtype=float).ravel(), estimate)
        prediction = self.predictor.predict(features, estimate)
        stage = case.study.strength_reduction
        top_first = getattr(case, "top_first", False)
        ceiling = stage.srf_max  # a top-first search goes on below its failed top, or its failed guard
        if top_first and getattr(case, "guard", None) is not None and stage.srf_min <= case.guard < stage.srf_max:
            ceiling = case.guard
        if prediction is not None and top_first and prediction.fos > ceiling:
            prediction = dataclasses.replace(prediction, fos=ceiling, basis=prediction.basis + ", below srf_max")
        if prediction is None or not stage.srf_min <= prediction.fos <= stage.srf_max:
            return None  # the full search of the stage's range (a FOS outside it is found as without a window)
        window = search_window(prediction, stage.fos_tolerance)
        if top_first and window[1] > ceiling:  # (its srf_max, or its guard, has failed)
            shift = window[1] - ceiling
            window = (max(round(window[0] - shift, 4), 0.01), ceiling, window[2])
        self.windows[case.case_id] = (prediction, window)
        return window

    def limit_equilibrium(self, study) -> float:
        """The study's limit-equilibrium F (NaN: none), once per section, soil, water and loads."""
        from workflows.fos.critical_circle import critical_circle

        key = (study.geometry, study.materials, study.water, study.loads, study.seepage)
        if key not in self.estimates:
            try:
                circle = critical_circle(study, quick=True)
            except (ValueError, IndexError, ZeroDivisionError):
                circle = None
            self.estimates[key] = circle.fos if circle is not None else math.nan
        return self.estimates[key]

    def with_window(self, case, features, estimate: float | None = None):
        """``case`` with its window (module doc)."""
        window = self.window(case, features, estimate)
        return case if window is None else dataclasses.replace(case, window=window)

    def concluded(self, case_id: str, fos: float) -> None:
        """A case has concluded with ``fos`` (NaN: none): its ratio joins the fit."""
        features, estimate = self.pending.pop(case_id, (None, math.nan))
        if features is not None:
            self.predictor.observe(features, estimate, fos)


class PredictedFeed:
    """A study's strength-reduction cases handed out in :func:`maximin_order` and in
    :class:`Generations`, each with its window (:class:`WindowPredictor`).  ``features``: each case's
    numbers (module doc)."""

    def __init__(self, cases: list, features: list, largest_generation: int = 8):
        order = maximin_order(np.array(features, dtype=float).reshape(len(cases), -1)) if cases else []
        self.cases = [cases[i] for i in order]
        self.features = [features[i] for i in order]
        self.generations = Generations(len(cases), largest_generation)
        self.windows = WindowPredictor()
        self.n_concluded = 0
        self.order = {case.case_id: i for i, case in enumerate(self.cases)}

    def to_come(self) -> int:
        return len(self.cases) - self.generations.given

    def more(self, count: int) -> list:
        """Up to ``count`` cases of the generation under way (the next once all before have concluded,
        after the FOS of those join the prediction: :meth:`Generations.released`)."""
        start = self.generations.given
        for case_id, fos in self.generations.released(self.n_concluded):
            self.windows.concluded(case_id, fos)
        take = min(count, self.generations.room(self.n_concluded))
        self.generations.take(take)
        return [self.windows.with_window(case, features)
                for case, features in zip(self.cases[start:start + take], self.features[start:start + take])]

    def concluded(self, case_id: str, fos: float) -> None:
        """A case's FOS, held until its whole generation has concluded (:meth:`Generations.hold`)."""
        self.n_concluded += 1
        self.generations.hold(self.order.get(case_id, len(self.order)), (case_id, fos))
