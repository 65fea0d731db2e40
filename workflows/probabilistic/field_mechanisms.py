"""The mechanisms of a probabilistic study's realisations of random fields, and the FOS they predict.

A realisation of spatially variable soil fails along its weakest path near the critical circle of
the mean soil.  Its FOS is predicted (``workflows.fos.prediction``) from the strength of its fields
along the mechanisms of the realisations concluded before (:class:`FieldMechanisms`), or, while
none is known, along the candidate circles of the mean soil (:func:`field_estimate`); the
regression of the predictor takes each field's weak-path quantile over the critical zone
(:func:`mechanism_means`) as a variable.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from workflows.fos.critical_circle import critical_circle
from workflows.random_field.table import RandomField
from workflows.random_field.values import node_properties
from workflows.scene import assign_materials, cloud


def _values_at_particles(study) -> dict[str, np.ndarray]:
    """property -> (n,) values of the study's realisation of its fields at its particles."""
    node_xy_m, node_spacing_m = cloud(study)
    return node_properties(study.random_field, study.materials, node_xy_m, node_spacing_m,
                           assign_materials(study, node_xy_m))


def critical_zone(study) -> np.ndarray:
    """(n,) bool over the study's particles: those within two spacings (at least a tenth of the slope's
    height) of the critical circle of its mean soil (``fos.critical_circle``, quick), where the
    mechanisms of its realisations run; every particle where no circle is found."""
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
    values = _values_at_particles(study)
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
    if not circles:
        return math.nan
    node_xy_m, _ = cloud(study)
    values = _values_at_particles(study)
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
        values = _values_at_particles(study)
        fields = []
        for entry in study.random_field.properties:
            field = values.get(entry.property)
            if field is not None:
                fields.append(np.tan(np.radians(field)) if entry.property.endswith("_deg") else field)
        return fields

    def add(self, study, line_x_m, line_y_m, fos: float) -> None:
        """Realisation ``study``'s slip line and FOS (NaN: left out)."""
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
