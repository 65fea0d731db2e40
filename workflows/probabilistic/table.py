"""``[probabilistic]``: random variables of a study and how its realisations are drawn and judged."""

from __future__ import annotations

import math
from dataclasses import dataclass

from workflows.distributions import DISTRIBUTIONS, Distribution, listed
from workflows.fields import Record, StudyError, any_values, boolean, integer, number, tables, text
from workflows.probabilistic.kinds import COMPUTATIONS, METHODS, Computation, Method, methods_text
from workflows.random_field.table import spread_problem

MAX_REALISATIONS = 100_000
KEEP_FIELDS = ("failed", "all", "none")
BOUNDED = ", ".join(name for name, kind in DISTRIBUTIONS.items() if kind.bounded)
"""The distributions that take bounds low and high."""


@dataclass(frozen=True, kw_only=True)
class RandomVariable(Record):
    """One study field drawn anew for each realisation."""

    path: str = text("the field, by its path as in [sweep]: `materials.soil.cohesion_pa`")
    distribution: str = text(listed(DISTRIBUTIONS), choices=tuple(DISTRIBUTIONS))
    mean: float | None = number("1", "mean, in the field's unit; default the field's value in the study",
                                default=None)
    std: float | None = number("1", "standard deviation, in the field's unit (or give cov)", default=None, gt=0.0)
    cov: float | None = number("1", "coefficient of variation std / mean (or give std)", default=None, gt=0.0,
                               le=10.0)
    low: float | None = number("1", f"*{BOUNDED}:* lower bound", default=None)
    high: float | None = number("1", f"*{BOUNDED}:* upper bound", default=None)

    @property
    def kind(self) -> Distribution:
        """The distribution ``distribution`` names (``workflows.distributions``)."""
        return DISTRIBUTIONS[self.distribution]

    def check(self):
        kind = self.kind
        if kind.by_bounds:
            if self.low is None or self.high is None:
                raise StudyError("low" if self.low is None else "high",
                                 f"a {self.distribution} variable needs low and high")
            for name in ("mean", "std", "cov"):
                if getattr(self, name) is not None:
                    raise StudyError(name, f"a {self.distribution} variable is given by low and high only")
        else:
            if (self.std is None) == (self.cov is None):
                raise StudyError("std", "give std or cov (one of them)")
            if not kind.bounded and (self.low is not None or self.high is not None):
                raise StudyError("low" if self.low is not None else "high",
                                 f"applies to {BOUNDED.replace(', ', ' and ')}, not {self.distribution}")
        if kind.bounded and self.low is not None and self.high is not None and not self.low < self.high:
            raise StudyError("high", f"must be above low ({self.low:g}), got {self.high:g}")
        if kind.positive and self.mean is not None and self.mean <= 0.0:
            raise StudyError("mean", f"a {self.distribution} variable needs a mean > 0")
        if self.mean is not None and not kind.by_bounds:
            problem = spread_problem(self.mean, self.std if self.std is not None else self.cov * abs(self.mean),
                                     self.cov is not None)
            if problem is not None:
                raise StudyError(*problem)


@dataclass(frozen=True, kw_only=True)
class Probabilistic(Record):
    """A probabilistic study: the study once per realisation of its random variables."""

    variables: tuple = tables(RandomVariable, "the random variables (none: only a [random_field] varies)",
                              unique="path")
    correlation: tuple | None = any_values(
        "correlation matrix of the variables themselves, in their order (rows of numbers, symmetric, ones on "
        "the diagonal); default uncorrelated", default=None,
    )
    method: str = text(methods_text(), default="monte_carlo", choices=tuple(METHODS))
    realisations: int = integer("number of realisations (form, point_estimate: the most FOS searches)", ge=1,
                                le=MAX_REALISATIONS)
    seed: int = integer("the seed: realisation i of monte_carlo is the same whatever the count", default=1, ge=0)
    compute: str = text(
        "; ".join(f"`{name}`: {computation.description}" for name, computation in COMPUTATIONS.items()),
        default="verdict", choices=tuple(COMPUTATIONS),
    )
    pf_interval_width: float | None = number(
        "1", "stop once the 95% interval of pf is at most this wide (checked after each batch of "
        "100 realisations; `realisations` is then the most); default: compute them all", default=None, gt=0.0, lt=1.0,
    )
    factor: float = number("1", "the SRF a realisation is judged at: it fails if its run at factor fails (verdict) "
                           "or its FOS is below factor (fos)", default=1.0, gt=0.0)
    keep_fields: str = text(
        "which realisations keep the final particle state in their run files (`OUT/cases/realisation_<i>/srf_*.nc`): "
        "`failed` (their failed runs: the mechanism), `all`, or `none`; every run file keeps its histories and "
        "verdict whatever this says (disk use per 1,000 realisations: docs/benchmarks.md)",
        default="failed", choices=KEEP_FIELDS,
    )
    keep_fields_first: int = integer("the first this many realisations keep the particle state of all their runs "
                                     "too, stable or failed", default=0, ge=0)
    fos_tolerance: float = number(
        "1", "*form, point_estimate:* the FOS bracket of each point's search (its stage's fos_tolerance, set "
        "tighter: FORM's finite differences must stand well above it)", default=0.002, gt=0.0, lt=0.1)
    form_step: float = number(
        "1", "*form:* the finite-difference step, in standard deviations of the standard normal variables; it "
        "should change the FOS by several brackets (the report names a variable whose change is within 3)",
        default=0.5, gt=0.0, le=3.0)
    form_tolerance: float = number("1", "*form:* stop once beta changes by at most this between iterations",
                                   default=0.02, gt=0.0, lt=1.0)
    sorm: bool = boolean("*form:* once FORM has converged, correct its pf by the limit state's curvatures at the design "
                         "point (SORM: Breitung, and Hohenbichler-Rackwitz): one more round of 1 + 2(n-1)^2 + 2 FOS "
                         "searches for n variables (21 for 4; none for one variable, where SORM is FORM)",
                         default=False)
    sorm_step: float = number(
        "1", "*form with sorm:* the central differences' step about the design point, in standard deviations of the "
        "standard normal variables; a second difference must stand above the brackets (the report bounds the "
        "curvatures' noise)", default=1.0, gt=0.0, le=3.0)
    samples_per_level: int = integer("*subset_simulation:* the FOS searches of each level (its first a Monte Carlo "
                                     "sample); samples_per_level * p0 Markov chains make each next level",
                                     default=500, ge=10, le=MAX_REALISATIONS)
    p0: float = number("1", "*subset_simulation:* the conditional probability of each level (its threshold the "
                       "p0-quantile of the level's FOS); 1 / p0 a whole number", default=0.1, gt=0.0, le=0.5)

    @property
    def method_kind(self) -> Method:
        """The method ``method`` names (``workflows.probabilistic.kinds``)."""
        return METHODS[self.method]

    @property
    def computation(self) -> Computation:
        """What ``compute`` names (``workflows.probabilistic.kinds``)."""
        return COMPUTATIONS[self.compute]

    def check_in_study(self, study) -> None:
        """Something to draw, a strength reduction to judge each realisation by, no [refinement] beside it."""
        if not self.variables and study.random_field is None:
            raise StudyError("probabilistic.variables", "give a random variable, or a [random_field]")
        if study.strength_reduction is None:
            raise StudyError("probabilistic", "a probabilistic study judges each realisation by strength "
                             "reduction: it needs a strength_reduction stage")
        if study.refinement is not None:
            raise StudyError("probabilistic", "[probabilistic] and [refinement] in one study are not supported yet")
        self.method_kind.check_in_study(study)

    def check(self):
        n = len(self.variables)
        if self.sorm and self.method != "form":
            raise StudyError("sorm", f'applies to method = "form" only, not {self.method}')
        self.method_kind.check(self, n)
        if self.correlation is not None:
            rows = self.correlation
            if len(rows) != n or any(not isinstance(row, (list, tuple)) or len(row) != n for row in rows):
                raise StudyError("correlation", f"must be {n} rows of {n} numbers, one per variable")
            for i, row in enumerate(rows):
                for j, value in enumerate(row):
                    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                        raise StudyError(f"correlation[{i}][{j}]", f"must be a number, got {value!r}")
                    if i == j and value != 1:
                        raise StudyError(f"correlation[{i}][{j}]", f"the diagonal must be 1, got {value!r}")
                    if not -1 < value <= 1 or value != rows[j][i]:
                        raise StudyError(f"correlation[{i}][{j}]", "must lie in (-1, 1) and equal "
                                         f"correlation[{j}][{i}]")
