"""``[random_field]``: soil properties that vary from point to point, as the study file declares them.

Each entry of ``[[random_field.properties]]`` makes one property of one material a random field
(Griffiths & Fenton 2004) of a correlation model (``workflows.random_field.correlation``) and scales of
fluctuation, with a point law

    normal:     X = mean + std G
    lognormal:  X = exp(mu_ln + sigma_ln G),   sigma_ln^2 = ln(1 + cov^2),  mu_ln = ln(mean) - sigma_ln^2 / 2

of a standard Gaussian field ``G``; two properties of one material may be cross-correlated (one
correlation structure for both).  The checks refuse a field that leaves its property's range, or
breaks an order of its material's properties, with a probability above
:data:`OUTSIDE_RANGE_LIMIT`.  Drawing the fields and their values at the particles is
``workflows.random_field.values``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from workflows.distributions import FIELD_DISTRIBUTIONS, NORMAL, Distribution
from workflows.engineering_units import spellings
from workflows.fields import (
    NUMBER,
    Record,
    StudyError,
    any_values,
    integer,
    name_field,
    number,
    specs,
    tables,
    text,
)
from workflows.random_field.correlation import CORRELATION_MODELS, CorrelationModel

COMBINATION_TOLERANCE = 1e-9
"""How far the squares of a ``combination``'s weights may sum from 1 (rounding of the chains' products)."""
SEEPAGE_PROPERTY = "permeability_m_s"
"""The one property of a field that is no property of the core's: the conductivity the steady flow
takes (``workflows.seepage.flow``), with ``[seepage]``."""
OUTSIDE_RANGE_LIMIT = 1e-6
"""A normal field whose point value leaves its field's allowed range with a probability above this is
refused (lognormal instead); below it, values beyond the bound are set to the bound.  So is a field
that breaks an order of its material's properties (:data:`ORDERED`) with a probability above it."""
ORDERED = (("dilation_deg", "friction_deg"), ("residual_friction_deg", "friction_deg"),
           ("residual_cohesion_pa", "cohesion_pa"))
"""Properties of one material that must not exceed another at any particle (the core refuses
psi > phi, and a residual strength above the peak): (lower, upper).  A random field of either is
refused where a point breaks the order with a probability above :data:`OUTSIDE_RANGE_LIMIT`; below
it, the lower property is set to the upper at the rare particles that do (psi = phi there)."""


def spread_problem(mean: float, std: float, cov_given: bool) -> tuple[str, str] | None:
    """(the field to blame, why) when a random value of ``mean`` and standard deviation ``std`` would
    not vary: a coefficient of variation of a zero mean (no spread at all), or a std too small to
    change the mean in floating point; None when it varies.  Realisations that do not differ are
    one computation, not independent samples: they would make pf an interval of copies."""
    if cov_given and mean == 0.0:
        return "cov", ("the mean is 0, so a coefficient of variation (std / mean) gives no spread: give std, "
                       "the spread in the field's unit, instead")
    if not std > 0.0 or mean + std == mean:
        return "std" if not cov_given else "cov", (f"a std of {std:.3g} about a mean of {mean:.6g} changes no value "
                                                   "(a random value needs a spread)")
    return None


def _normal_cdf(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


def order_broken_probability(lower: tuple, upper: tuple, rho: float = 0.0) -> float:
    """P(X_lower > X_upper) at a point, each side (its ``workflows.distributions`` point law, mean, std)
    of a field (its standard Gaussian G, ``rho`` the correlation of the two G's) or (None, x, 0) of a
    value: for two normals Phi((m_l - m_u) / sqrt(s_l^2 + s_u^2 - 2 rho s_l s_u)); otherwise the
    integral over G_u of P(G_l > t_l(x_u(G_u)) | G_u), G_l given G_u normal of mean rho G_u and
    variance 1 - rho^2 (quadrature)."""

    def gaussian_of(side, x):  # the G whose value is x (-inf for x <= 0 of a lognormal)
        return side[0].gaussian_of(side[1], side[2], x)

    def value_of(side, g):
        return side[0].point_value(side[1], side[2], g)

    if lower[0] is None and upper[0] is None:
        return float(lower[1] > upper[1])
    if lower[0] is None:  # P(X_u < x_l)
        return _normal_cdf(gaussian_of(upper, lower[1]))
    if upper[0] is None:  # P(X_l > x_u)
        return _normal_cdf(-gaussian_of(lower, upper[1]))
    if lower[0] is upper[0] is NORMAL:
        spread = math.sqrt(max(lower[2] ** 2 + upper[2] ** 2 - 2.0 * rho * lower[2] * upper[2], 0.0))
        return _normal_cdf((lower[1] - upper[1]) / spread) if spread > 0.0 else float(lower[1] > upper[1])
    from scipy import integrate  # scipy is heavy: imported only for a lognormal pair, never by the reader

    given = math.sqrt(1.0 - rho * rho)

    def integrand(g: float) -> float:
        density = math.exp(-0.5 * g * g) / math.sqrt(2.0 * math.pi)
        return density * _normal_cdf((rho * g - gaussian_of(lower, value_of(upper, g))) / given)

    return float(integrate.quad(integrand, -np.inf, np.inf, epsabs=1e-12, limit=200)[0])


def _law_text(side: tuple, prop: str) -> str:
    kind, mean, std = side
    return f"{prop} {mean:g}" if kind is None else f"a {kind.name} {prop} field of mean {mean:g} and std {std:g}"


@dataclass(frozen=True, kw_only=True)
class FieldProperty(Record):
    """One property of one material as a random field."""

    name: str = name_field("name of the field (for `correlated_with` and sweep paths: "
                           "`random_field.properties.<name>.cov`)")
    material: str = name_field("the material, by its name in [[materials]]")
    property: str = text("the material's field that varies: e.g. `cohesion_pa`, `undrained_shear_strength_pa`, "
                         "`friction_deg`, `youngs_modulus_pa`, `density_kg_m3`")
    distribution: str = text("`normal` or `lognormal` (a strength that must stay positive)",
                             choices=tuple(FIELD_DISTRIBUTIONS))
    mean: float | None = number("1", "point mean, in the property's unit; default the material's value",
                                default=None)
    std: float | None = number("1", "point standard deviation, in the property's unit (or give cov)", default=None,
                               gt=0.0)
    cov: float | None = number("1", "point coefficient of variation std / mean (or give std)", default=None, gt=0.0,
                               le=10.0)
    theta_x_m: float = number("m", "horizontal scale of fluctuation theta_h (Markov: rho = exp(-2 tau / theta))",
                              gt=0.0)
    theta_y_m: float | None = number("m", "vertical scale of fluctuation theta_v; default theta_x_m (isotropic)",
                                     default=None, gt=0.0)
    correlation_model: str = text(
        " or ".join(f"`{name}` ({model.formula})" for name, model in CORRELATION_MODELS.items())
        + ", with r the lag over theta", default="markov", choices=tuple(CORRELATION_MODELS),
    )
    correlated_with: str | None = text("the name of another field of this material: the two Gaussian fields "
                                       "correlate by `correlation`", default=None)
    correlation: float | None = number("1", "correlation coefficient with `correlated_with` (of ln X for lognormal)",
                                       default=None, gt=-1.0, lt=1.0)

    def law(self) -> Distribution:  # a method, as thetas_m
        """The point law ``distribution`` names (``workflows.distributions``)."""
        return FIELD_DISTRIBUTIONS[self.distribution]

    def model(self) -> CorrelationModel:  # a method, as thetas_m
        """The correlation model ``correlation_model`` names (``workflows.random_field.correlation``)."""
        return CORRELATION_MODELS[self.correlation_model]

    def thetas_m(self) -> tuple[float, float]:  # a method: the field `property` hides the builtin here
        """(theta_x, theta_y) in m."""
        return self.theta_x_m, self.theta_x_m if self.theta_y_m is None else self.theta_y_m

    def check(self):
        if (self.std is None) == (self.cov is None):
            raise StudyError("std", "give std or cov (one of them)")
        if (self.correlated_with is None) != (self.correlation is None):
            raise StudyError("correlation" if self.correlation is None else "correlated_with",
                             "give correlated_with and correlation together")
        if self.correlated_with == self.name:
            raise StudyError("correlated_with", "a field cannot be correlated with itself")


@dataclass(frozen=True, kw_only=True)
class RandomField(Record):
    """Spatially variable soil: properties of materials as random fields, one realisation of them."""

    properties: tuple = tables(FieldProperty, "the properties that vary", min_items=1)
    seed: int = integer("the seed of the fields", default=1, ge=0)
    realisation: int = integer("which realisation of the fields (a probabilistic study sets it for each of its "
                               "realisations)", default=0, ge=0)
    combination: tuple | None = any_values(
        "the standard normal vector of the fields as a weighted sum of those of other realisations, rows "
        "[realisation, weight] whose weights' squares sum to 1 (subset simulation's Markov chains write it: rho times "
        "the chain's state, sqrt(1 - rho^2) times the candidate's own); `realisation` then only names the case; "
        "absent: the realisation's own", default=None)

    def check(self):
        """A combination's rows are [realisation >= 0, finite weight], distinct, their weights' squares summing
        to 1 (a standard normal vector again)."""
        if self.combination is None:
            return
        seen = set()
        for i, row in enumerate(self.combination):
            if (not isinstance(row, tuple) or len(row) != 2 or isinstance(row[0], bool) or not isinstance(row[0], int)
                    or row[0] < 0 or isinstance(row[1], bool) or not isinstance(row[1], (int, float))
                    or not math.isfinite(row[1])):
                raise StudyError(f"combination[{i}]", f"must be [realisation (an integer >= 0), weight (a number)], "
                                 f"got {list(row) if isinstance(row, tuple) else row!r}")
            if row[0] in seen:
                raise StudyError(f"combination[{i}]", f"realisation {row[0]} appears twice")
            seen.add(row[0])
        total = sum(float(row[1]) ** 2 for row in self.combination)
        if abs(total - 1.0) > COMBINATION_TOLERANCE:
            raise StudyError("combination", f"the weights' squares sum to {total:.9g}, not 1: the sum would not be "
                             "a standard normal vector")

    def terms(self) -> tuple[tuple[int, float], ...]:
        """(realisation, weight) of each standard normal vector the fields are made of (``combination``)."""
        if self.combination is None:
            return ((self.realisation, 1.0),)
        return tuple((int(r), float(w)) for r, w in self.combination)

    def check_in_study(self, study) -> None:
        """Every entry names a material and one of its numeric properties, with a valid mean (module doc)."""
        materials = {material.name: material for material in study.materials}
        seen: dict[tuple[str, str], str] = {}
        for i, entry in enumerate(self.properties):
            where = f"random_field.properties[{i}]"
            if (entry.material, entry.property) in seen:
                raise StudyError(f"{where}.property", f"{entry.material}'s {entry.property} is already the field "
                                 f"{seen[entry.material, entry.property]!r}")
            seen[entry.material, entry.property] = entry.name
            material = materials.get(entry.material)
            if material is None:
                raise StudyError(f"{where}.material", f"no material named {entry.material!r} "
                                 f"(known: {', '.join(materials)})")
            numeric = [name for name, spec in specs(type(material)).items() if spec.kind is NUMBER]
            varying = [p for p in numeric if p in material.core_row()] + [SEEPAGE_PROPERTY] * (study.seepage is not None)
            si_name = spellings(entry.property)[0]
            if entry.property not in varying and si_name in varying:
                raise StudyError(f"{where}.property", f"{entry.property!r} names {si_name} in other units: a field "
                                 f"names the property in SI units, {si_name!r}, and gives its mean and std in them "
                                 f"(the mean by default the material's value, however the file gives it)")
            if entry.property not in varying:
                raise StudyError(f"{where}.property", f"{entry.property!r} is no property of {entry.material!r} that "
                                 f"can vary (a {material.model}: {', '.join(varying)}"
                                 + ("; permeability_m_s with [seepage]" if study.seepage is None else "") + ")")
            if entry.property == "density_kg_m3" and study.water is not None:
                raise StudyError(f"{where}.property", "a random density with [water] is not supported (the water "
                                 "sets saturated densities per particle)")
            mean, std = self.moments(entry, material)
            spec = specs(type(material))[entry.property]
            if entry.law().positive and not mean > 0.0:
                raise StudyError(f"{where}.mean", f"a {entry.distribution} field needs a mean > 0, got {mean:g}")
            problem = spread_problem(mean, std, entry.cov is not None)
            if problem is not None:
                raise StudyError(f"{where}.{problem[0]}", f"{entry.material}'s {entry.property}: {problem[1]}")
            self._check_range(where, entry, spec, mean, std)
            if entry.correlated_with is not None:
                partner = next((p for p in self.properties if p.name == entry.correlated_with), None)
                if partner is None or partner.material != entry.material or partner.correlated_with is not None:
                    raise StudyError(f"{where}.correlated_with", f"must name another field of {entry.material!r} "
                                     "that is not itself correlated_with a third")
                if (partner.correlation_model, partner.thetas_m()) != (entry.correlation_model, entry.thetas_m()):
                    raise StudyError(f"{where}.correlated_with", "cross-correlated fields share one correlation "
                                     f"structure: give the correlation_model and thetas of {partner.name!r}")
        partners = [entry.correlated_with for entry in self.properties if entry.correlated_with is not None]
        if len(set(partners)) < len(partners):
            raise StudyError("random_field.properties", "a field can be the partner of one correlated field only "
                             f"({', '.join(partners)})")
        self._check_order(materials)

    def _check_order(self, materials: dict) -> None:
        """StudyError naming a field that breaks an order of its material's properties (:data:`ORDERED`:
        dilation at most friction, a residual strength at most the peak) at a point with a probability
        above :data:`OUTSIDE_RANGE_LIMIT` (:func:`order_broken_probability`)."""
        index = {(entry.material, entry.property): k for k, entry in enumerate(self.properties)}
        for name, material in materials.items():
            for lower, upper in ORDERED:
                ks = [index.get((name, prop)) for prop in (lower, upper)]
                if ks == [None, None] or any(getattr(material, prop, None) is None for prop in (lower, upper)):
                    continue  # no field, or a property the material leaves to the other (a residual: the peak)
                sides = [self._point_law(k, material, prop) for k, prop in zip(ks, (lower, upper))]
                rho = 0.0
                if None not in ks:
                    a, b = (self.properties[k] for k in ks)
                    rho = a.correlation if a.correlated_with == b.name else (
                        b.correlation if b.correlated_with == a.name else 0.0)
                probability = order_broken_probability(sides[0], sides[1], rho)
                if probability > OUTSIDE_RANGE_LIMIT:
                    k = ks[0] if ks[0] is not None else ks[1]
                    entry = self.properties[k]
                    raise StudyError(f"random_field.properties[{k}].distribution", (
                        f"{name}'s {lower} exceeds its {upper} at a point with probability {probability:.2g} "
                        f"({_law_text(sides[0], lower)} against {_law_text(sides[1], upper)}); the soil needs "
                        f"{lower} <= {upper} everywhere (the core refuses the particles that do not): narrow "
                        f"the field{'s' if None not in ks else ''}, or move {entry.property}'s mean away"))

    def _point_law(self, k: int | None, material, prop: str) -> tuple:
        """(point law, mean, std) of the point value of field ``k``, or (None, x, 0) of the material's own
        value of ``prop`` where no field varies it."""
        if k is None:
            return None, float(getattr(material, prop)), 0.0
        entry = self.properties[k]
        return (entry.law(), *self.moments(entry, material))

    def embeddings_key(self, study) -> tuple:
        """What the fields' circulant embeddings depend on (equal keys: one check of them serves both): the
        particles of each field's material (the geometry and the materials' regions), the correlation
        model and scales of fluctuation."""
        regions = tuple((material.name, material.region_m) for material in study.materials)
        return study.geometry, regions, tuple((entry.material, entry.correlation_model, entry.thetas_m())
                                              for entry in self.properties)

    @staticmethod
    def moments(entry: FieldProperty, material) -> tuple[float, float]:
        """(mean, std) of the entry's point value: given, or from the material's value and the cov."""
        mean = getattr(material, entry.property) if entry.mean is None else entry.mean
        std = entry.std if entry.std is not None else entry.cov * abs(mean)
        return float(mean), float(std)

    @staticmethod
    def _check_range(where: str, entry: FieldProperty, spec, mean: float, std: float) -> None:
        for op, bound in spec.bounds:
            if entry.law().positive and op in (">", ">=") and bound <= 0.0:
                continue
            z = entry.law().gaussian_of(mean, std, bound)
            outside = _normal_cdf(z) if op in (">", ">=") else _normal_cdf(-z)
            if outside > OUTSIDE_RANGE_LIMIT:
                raise StudyError(f"{where}.distribution", f"a {entry.distribution} field of mean {mean:g} and std "
                                 f"{std:g} leaves {entry.property} {op} {bound:g} with probability {outside:.2g}; "
                                 "use a lognormal field or a smaller std")
