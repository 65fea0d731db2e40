"""``[random_field]``: soil properties that vary from point to point, and their values at the particles.

Each entry of ``[[random_field.properties]]`` makes one property of one material a random field
(Griffiths & Fenton 2004): a standard Gaussian field ``G`` of the entry's correlation model and
scales of fluctuation (``workflows.probabilistic.random_field``), averaged over each particle's
cell, mapped to the property by

    normal:     X = mean + std G
    lognormal:  X = exp(mu_ln + sigma_ln G),   sigma_ln^2 = ln(1 + cov^2),  mu_ln = ln(mean) - sigma_ln^2 / 2

so that a point of the field has the entry's mean and standard deviation and a particle's value
has the reduced variance of its cell average (for lognormal, the average is taken of ln X, as
RFEM does).  Two properties of one material are cross-correlated through their Gaussian fields,
``G_b = rho G_a + sqrt(1 - rho^2) Z`` with ``Z`` independent of ``G_a`` (one correlation structure for
both, as Fenton & Griffiths' co-located model); for lognormal properties ``rho`` is the
correlation of ln X.

The field of realisation ``r`` with seed ``s`` is drawn from the stream
``SeedSequence([s, r], spawn_key=(FIELD_STREAM, crc32 of the field's name))``, so it depends on nothing
else (not on the other fields, the number of realisations or the worker),
and never coincides with the stream of ``[probabilistic]``'s random variables.  The values live
on the particles (``spfem_core.scene.Scene.node_properties``), and particles are the mesh's
nodes: remeshing never moves a value from one particle to another.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from workflows.fields import Record, StudyError, integer, name_field, number, specs, tables, text
from workflows.probabilistic.random_field import (
    MAX_EMBEDDING,
    MODELS,
    EmbeddingError,
    ParticleField,
    ParticleGrid,
    largest_theta_scale,
    lognormal_parameters,
)
from workflows.probabilistic.table import spread_problem

FIELD_STREAM = 7
"""The first spawn key of a field's random stream (module doc): apart from every other stream."""
FIELD_DISTRIBUTIONS = ("normal", "lognormal")
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


def _normal_cdf(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


def order_broken_probability(lower: tuple, upper: tuple, rho: float = 0.0) -> float:
    """P(X_lower > X_upper) at a point, each side ("normal" or "lognormal", mean, std) of a field (its
    standard Gaussian G, ``rho`` the correlation of the two G's) or ("value", x, 0): for two normals
    Phi((m_l - m_u) / sqrt(s_l^2 + s_u^2 - 2 rho s_l s_u)); otherwise the integral over G_u of
    P(G_l > t_l(x_u(G_u)) | G_u), G_l given G_u normal of mean rho G_u and variance 1 - rho^2
    (quadrature)."""

    def gaussian_of(side, x):  # the G whose value is x (-inf for x <= 0 of a lognormal)
        kind, mean, std = side
        if kind == "lognormal":
            mu, sigma = lognormal_parameters(mean, std / mean)
            return (math.log(x) - mu) / sigma if x > 0.0 else -math.inf
        return (x - mean) / std

    def value_of(side, g):
        kind, mean, std = side
        if kind == "lognormal":
            mu, sigma = lognormal_parameters(mean, std / mean)
            return math.exp(mu + sigma * g)
        return mean + std * g

    if lower[0] == "value" and upper[0] == "value":
        return float(lower[1] > upper[1])
    if lower[0] == "value":  # P(X_u < x_l)
        return _normal_cdf(gaussian_of(upper, lower[1]))
    if upper[0] == "value":  # P(X_l > x_u)
        return _normal_cdf(-gaussian_of(lower, upper[1]))
    if lower[0] == upper[0] == "normal":
        spread = math.sqrt(max(lower[2] ** 2 + upper[2] ** 2 - 2.0 * rho * lower[2] * upper[2], 0.0))
        return _normal_cdf((lower[1] - upper[1]) / spread) if spread > 0.0 else float(lower[1] > upper[1])
    from scipy import integrate  # only for a lognormal pair

    given = math.sqrt(1.0 - rho * rho)

    def integrand(g: float) -> float:
        density = math.exp(-0.5 * g * g) / math.sqrt(2.0 * math.pi)
        return density * _normal_cdf((rho * g - gaussian_of(lower, value_of(upper, g))) / given)

    return float(integrate.quad(integrand, -np.inf, np.inf, epsabs=1e-12, limit=200)[0])


def _law_text(side: tuple, prop: str) -> str:
    kind, mean, std = side
    return f"{prop} {mean:g}" if kind == "value" else f"a {kind} {prop} field of mean {mean:g} and std {std:g}"


@dataclass(frozen=True, kw_only=True)
class FieldProperty(Record):
    """One property of one material as a random field."""

    name: str = name_field("name of the field (for `correlated_with` and sweep paths: "
                           "`random_field.properties.<name>.cov`)")
    material: str = name_field("the material, by its name in [[materials]]")
    property: str = text("the material's field that varies: e.g. `cohesion_pa`, `undrained_shear_strength_pa`, "
                         "`friction_deg`, `youngs_modulus_pa`, `density_kg_m3`")
    distribution: str = text("`normal` or `lognormal` (a strength that must stay positive)", choices=FIELD_DISTRIBUTIONS)
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
    correlation_model: str = text("`markov` (exp(-2 r)) or `gaussian` (exp(-pi r^2)), with r the lag over theta",
                                  default="markov", choices=MODELS)
    correlated_with: str | None = text("the name of another field of this material: the two Gaussian fields "
                                       "correlate by `correlation`", default=None)
    correlation: float | None = number("1", "correlation coefficient with `correlated_with` (of ln X for lognormal)",
                                       default=None, gt=-1.0, lt=1.0)

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

    def check_in_study(self, study) -> None:
        """Every entry names a material and one of its numeric properties, with a valid mean (module doc)."""
        materials = {material.name: material for material in study.materials}
        seen = {}
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
            numeric = [name for name, spec in specs(type(material)).items() if spec.type == "number"]
            varying = [p for p in numeric if p in material.core_row()] + [SEEPAGE_PROPERTY] * (study.seepage is not None)
            from workflows.study.engineering_units import spellings  # (the study package imports this module)

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
            if entry.distribution == "lognormal" and not mean > 0.0:
                raise StudyError(f"{where}.mean", f"a lognormal field needs a mean > 0, got {mean:g}")
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
                probability = order_broken_probability(*sides, rho)
                if probability > OUTSIDE_RANGE_LIMIT:
                    k = ks[0] if ks[0] is not None else ks[1]
                    entry = self.properties[k]
                    raise StudyError(f"random_field.properties[{k}].distribution", (
                        f"{name}'s {lower} exceeds its {upper} at a point with probability {probability:.2g} "
                        f"({_law_text(sides[0], lower)} against {_law_text(sides[1], upper)}); the soil needs "
                        f"{lower} <= {upper} everywhere (the core refuses the particles that do not): narrow "
                        f"the field{'s' if None not in ks else ''}, or move {entry.property}'s mean away"))

    def _point_law(self, k: int | None, material, prop: str) -> tuple:
        """("normal" or "lognormal", mean, std) of the point value of field ``k``, or ("value", x, 0) of
        the material's own value of ``prop`` where no field varies it."""
        if k is None:
            return "value", float(getattr(material, prop)), 0.0
        entry = self.properties[k]
        return (entry.distribution, *self.moments(entry, material))

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
            if entry.distribution == "lognormal" and op in (">", ">=") and bound <= 0.0:
                continue
            if entry.distribution == "lognormal":
                mu, sigma = lognormal_parameters(mean, std / mean)
                z = (math.log(bound) - mu) / sigma if bound > 0.0 else -math.inf
            else:
                z = (bound - mean) / std
            outside = _normal_cdf(z) if op in (">", ">=") else _normal_cdf(-z)
            if outside > OUTSIDE_RANGE_LIMIT:
                raise StudyError(f"{where}.distribution", f"a {entry.distribution} field of mean {mean:g} and std "
                                 f"{std:g} leaves {entry.property} {op} {bound:g} with probability {outside:.2g}; "
                                 "use a lognormal field or a smaller std")

    def _too_long(self, k: int, grid: ParticleGrid) -> StudyError:
        """The refusal of entry ``k``'s scales of fluctuation, too long for the circulant embedding on the
        grid of its material's particles: the field named, the longest scales this section holds."""
        entry = self.properties[k]
        theta_x_m, theta_y_m = entry.thetas_m()
        scale = largest_theta_scale(entry.correlation_model, theta_x_m, theta_y_m, grid)
        lx, ly = grid.extent_m
        field = "theta_y_m" if entry.theta_y_m is not None and theta_y_m / ly > theta_x_m / lx else "theta_x_m"
        longest = (f"theta_x_m up to {scale * theta_x_m:.2g} m" if entry.theta_y_m is None else
                   f"theta_x_m up to {scale * theta_x_m:.2g} m with theta_y_m {scale * theta_y_m:.2g} m (in this "
                   "ratio)")
        return StudyError(f"random_field.properties[{k}].{field}", (
            f"{entry.name!r}: a {entry.correlation_model} field with theta = ({theta_x_m:g}, {theta_y_m:g}) m over "
            f"{entry.material!r} ({lx:.3g} m by {ly:.3g} m) has no circulant embedding of up to {MAX_EMBEDDING} "
            f"times its grid; this section holds {longest}; a longer scale of fluctuation needs another method "
            "(not yet)"))

    @staticmethod
    def _ordered(materials, node_material: np.ndarray, out: dict[str, np.ndarray]) -> None:
        """The lower property of each order (:data:`ORDERED`) set to the upper at the particles whose
        fields break it (rare: :meth:`_check_order`), in ``out`` (NaN: a particle of another material)."""
        for lower, upper in ORDERED:
            if lower not in out and upper not in out:
                continue
            for row, material in enumerate(materials):
                if any(getattr(material, prop, None) is None for prop in (lower, upper)):
                    continue
                mine = node_material == row
                values = {prop: np.where(np.isnan(out[prop][mine]), getattr(material, prop), out[prop][mine])
                          if prop in out else np.full(int(mine.sum()), float(getattr(material, prop)))
                          for prop in (lower, upper)}
                broken = values[lower] > values[upper]
                if broken.any():
                    column = out.setdefault(lower, np.full(node_material.shape[0], np.nan))
                    column[mine] = np.where(broken, values[upper], column[mine])

    def node_properties(self, materials, node_xy_m: np.ndarray, node_spacing_m: np.ndarray,
                        node_material: np.ndarray) -> dict[str, np.ndarray]:
        """property -> (n,) values at the particles (NaN: a particle of another material) of the study's
        ``materials`` (module doc)."""
        by_name = {material.name: row for row, material in enumerate(materials)}
        out: dict[str, np.ndarray] = {}
        fields: dict[tuple, ParticleField] = {}
        gaussian: dict[str, np.ndarray] = {}
        order = sorted(range(len(self.properties)), key=lambda k: self.properties[k].correlated_with is not None)
        for k in order:
            entry = self.properties[k]
            row = by_name[entry.material]
            mine = np.flatnonzero(node_material == row)
            if mine.size == 0:
                continue
            structure = (row, entry.correlation_model, entry.thetas_m())
            if structure not in fields:
                try:
                    fields[structure] = ParticleField(entry.correlation_model, *entry.thetas_m(), node_xy_m[mine, 0],
                                                      node_xy_m[mine, 1], node_spacing_m[mine])
                except EmbeddingError:
                    raise self._too_long(k, ParticleGrid.of(node_xy_m[mine, 0], node_xy_m[mine, 1],
                                                            node_spacing_m[mine])) from None
            stream = np.random.SeedSequence([self.seed, self.realisation], spawn_key=(FIELD_STREAM, zlib.crc32(entry.name.encode())))
            g = fields[structure].draw(np.random.default_rng(stream))[0]
            if entry.correlated_with is not None:
                rho = entry.correlation
                g = rho * gaussian[entry.correlated_with] + math.sqrt(1.0 - rho * rho) * g
            gaussian[entry.name] = g
            mean, std = self.moments(entry, materials[row])
            if entry.distribution == "lognormal":
                mu, sigma = lognormal_parameters(mean, std / mean)
                values = np.exp(mu + sigma * g)
            else:
                values = mean + std * g
            spec = specs(type(materials[row]))[entry.property]
            for op, bound in spec.bounds:  # a normal field's rare values beyond its range (OUTSIDE_RANGE_LIMIT)
                limit = {">": np.nextafter(bound, math.inf), "<": np.nextafter(bound, -math.inf)}.get(op, bound)
                values = np.maximum(values, limit) if op in (">", ">=") else np.minimum(values, limit)
            column = out.setdefault(entry.property, np.full(node_xy_m.shape[0], np.nan))
            column[mine] = values
        self._ordered(materials, node_material, out)
        return out


def critical_zone(study) -> np.ndarray:
    """(n,) bool over the study's particles: those within two spacings (at least a tenth of the slope's
    height) of the critical circle of its mean soil (``fos.critical_circle``, quick), where the
    mechanisms of its realisations run; every particle where no circle is found."""
    from workflows.fos.critical_circle import critical_circle
    from workflows.scene import cloud

    node_xy_m, _ = cloud(study)
    circle = critical_circle(study, quick=True)
    if circle is None:
        return np.ones(node_xy_m.shape[0], dtype=bool)
    (xc, yc), radius = circle.centre_m, circle.radius_m
    low, high = sorted((circle.entry_x_m, circle.exit_x_m))
    reach = max(2.0 * study.geometry.spacing_m, 0.1 * study.slope_height_m)
    to_arc = np.abs(np.hypot(node_xy_m[:, 0] - xc, node_xy_m[:, 1] - yc) - radius)
    zone = (to_arc <= reach) & (node_xy_m[:, 0] >= low - reach) & (node_xy_m[:, 0] <= high + reach) & (
        node_xy_m[:, 1] <= yc)
    return zone if zone.any() else np.ones(node_xy_m.shape[0], dtype=bool)


WEAK_PATH_QUANTILE = 0.2
"""The quantile of a field over the mechanism's zone that stands for its strength there: a mechanism
finds the weaker soil (on the undrained random-field study, the FOS of 19 realisations correlates
0.87 with the 20% quantile of cu near the critical circle, 0.85 with its harmonic mean, 0.69 with its
mean)."""


def mechanism_means(study, zone: np.ndarray) -> list[float]:
    """Each random field's ``WEAK_PATH_QUANTILE`` over the particles of ``zone`` (:func:`critical_zone`)
    in the study's realisation (a friction or dilation angle as its tangent): the strength along the
    mechanism, a predictor of the realisation's FOS (``fos.prediction``)."""
    from workflows.scene import assign_materials, cloud

    node_xy_m, node_spacing_m = cloud(study)
    values = study.random_field.node_properties(study.materials, node_xy_m, node_spacing_m,
                                                assign_materials(study, node_xy_m))
    means = []
    for entry in study.random_field.properties:
        field = values.get(entry.property)
        if field is None:
            continue
        inside = field[zone & np.isfinite(field)]
        if entry.property.endswith("_deg"):
            inside = np.tan(np.radians(inside))
        means.append(float(np.quantile(inside, WEAK_PATH_QUANTILE)) if inside.size else 0.0)
    return means


ARC_POINTS = 48
"""Points along each candidate circle where a realisation's fields are read."""


def field_estimate(study, circles) -> float:
    """A limit-equilibrium estimate of the FOS of the study's realisation of its fields: over the
    ``circles`` of its mean soil (``fos.critical_circle.candidate_circles``), the least of each circle's
    F times the ratio of each field's mean along it to the field's mean (for a cohesion or an undrained
    strength the circle's F scales with it; a friction angle by its tangent); NaN without circles."""
    from scipy.spatial import cKDTree  # (scipy: not for the study reader, which imports this module)

    from workflows.scene import assign_materials, cloud

    if not circles:
        return math.nan
    node_xy_m, node_spacing_m = cloud(study)
    values = study.random_field.node_properties(study.materials, node_xy_m, node_spacing_m,
                                                assign_materials(study, node_xy_m))
    by_name = {material.name: material for material in study.materials}
    tree = cKDTree(node_xy_m)
    best = math.inf
    for circle in circles:
        (xc, yc), radius = circle.centre_m, circle.radius_m
        low, high = sorted((circle.entry_x_m, circle.exit_x_m))
        x = np.linspace(low, high, ARC_POINTS + 2)[1:-1]
        points = np.column_stack([x, yc - np.sqrt(np.maximum(radius**2 - (x - xc) ** 2, 0.0))])
        nearest = tree.query(points)[1]
        ratio = 1.0
        for entry in study.random_field.properties:
            field = values.get(entry.property)
            if field is None:
                continue
            mean, _ = RandomField.moments(entry, by_name[entry.material])
            along = field[nearest]
            along = along[np.isfinite(along)]
            if not along.size or not mean:
                continue
            if entry.property.endswith("_deg"):
                ratio *= float(np.mean(np.tan(np.radians(along)))) / math.tan(math.radians(mean))
            else:
                ratio *= float(np.mean(along)) / mean
        best = min(best, circle.fos * ratio)
    return best if math.isfinite(best) else math.nan


MECHANISM_QUANTILE = 0.1
"""The quantile of the estimates from the earlier realisations' mechanisms that stands for a new
realisation's FOS: it fails on its weakest path (on the undrained random-field study, after 30
realisations: the ratio of the FOS to it varies 5.2% against 6.5% for the least of them, 7.1% for
their mean, 8% for the least circle of limit equilibrium through its fields)."""
LINE_POINTS = 80


class FieldMechanisms:
    """The mechanisms of a probabilistic study's concluded realisations (their slip lines, FOS and the
    strength along them), from which a new realisation's FOS is estimated: realisation j's FOS F_j times
    the ratio of the new realisation's mean strength along j's line to j's own, each field in turn (a
    friction angle by its tangent), the ``MECHANISM_QUANTILE`` of these over j (``fos.prediction``)."""

    def __init__(self, study):
        self.study = study
        self.lines: list[tuple[np.ndarray, float, np.ndarray]] = []  # (particles along it, F_j, its means)

    def _values(self, study) -> list[np.ndarray]:
        from workflows.scene import assign_materials, cloud

        node_xy_m, node_spacing_m = cloud(study)
        values = study.random_field.node_properties(study.materials, node_xy_m, node_spacing_m,
                                                    assign_materials(study, node_xy_m))
        fields = []
        for entry in study.random_field.properties:
            field = values.get(entry.property)
            if field is not None:
                fields.append(np.tan(np.radians(field)) if entry.property.endswith("_deg") else field)
        return fields

    def add(self, study, line_x_m, line_y_m, fos: float) -> None:
        """Realisation ``study``'s slip line and FOS (NaN: left out)."""
        from scipy.spatial import cKDTree  # (scipy: not for the study reader, which imports this module)

        from workflows.scene import cloud

        if not math.isfinite(fos) or len(line_x_m) < 2:
            return
        node_xy_m, _ = cloud(study)
        order = np.argsort(line_x_m)
        x = np.linspace(float(np.min(line_x_m)), float(np.max(line_x_m)), LINE_POINTS)
        y = np.interp(x, np.asarray(line_x_m)[order], np.asarray(line_y_m)[order])
        along = cKDTree(node_xy_m).query(np.column_stack([x, y]))[1]
        means = np.array([np.nanmean(field[along]) for field in self._values(study)])
        self.lines.append((along, fos, means))

    def estimate(self, study, circles) -> float:
        """The new realisation's estimated FOS (class doc); over the ``circles`` of the mean soil
        (:func:`field_estimate`) while no mechanism is known."""
        if not self.lines:
            return field_estimate(study, circles)
        fields = self._values(study)
        estimates = [fos * float(np.prod([np.nanmean(field[along]) / mean for field, mean in zip(fields, means)]))
                     for along, fos, means in self.lines]
        return float(np.quantile(estimates, MECHANISM_QUANTILE))
