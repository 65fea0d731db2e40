"""The FOS a probabilistic study's realisation of random fields is expected to have, from limit
equilibrium through its fields (the window of its search, ``workflows.fos.prediction``).

A realisation of spatially variable soil fails along its weakest path.  For a cohesive soil a slip
circle's F scales with the mean strength along its arc: on circle c of the mean soil, of factor of
safety F_c (Bishop, ``fos.critical_circle.candidate_circles``: every admissible circle of the grid
search),

    E = min_c  F_c  prod_k  mean_arc(field_k on c) / mean(field_k)

(each field k in turn; a friction angle by its tangent), the arc's mean over ``ARC_POINTS`` points
equally spaced along it (its length, not its width: Bishop's strength term sums c_i b_i / cos a_i),
read at the nearest particle.  The least over many circles finds the weak zones a realisation's
mechanism follows: on the undrained random-field study (200 realisations, COV 0.5, theta = H) the
ratio of its FOS to E varies 2.7% (relative rms of the prediction from the earlier generations), to
3.0% over the 400 least circles of the mean soil, 9.2% over the 40 least, and 6.1% for the earlier
estimate from the slip lines of the realisations before (``python -m benchmarks.field_predictors``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from workflows.fos.critical_circle import candidate_circles
from workflows.random_field.table import RandomField
from workflows.random_field.values import node_properties
from workflows.scene import assign_materials, cloud

ARC_POINTS = 64
"""Points along each circle, equally spaced along its arc, where a realisation's fields are read."""
CANDIDATES = 100_000
"""More circles than the grid search makes: every admissible one is a candidate."""


def arc_points_m(circle, count: int = ARC_POINTS) -> np.ndarray:
    """(count, 2) points equally spaced along ``circle``'s arc between its ends (inside it)."""
    (xc, yc), radius = circle.centre_m, circle.radius_m
    low, high = sorted((circle.entry_x_m, circle.exit_x_m))
    angles = np.arcsin(np.clip((np.array([low, high]) - xc) / radius, -1.0, 1.0))
    angle = np.linspace(angles[0], angles[1], count + 2)[1:-1]
    return np.column_stack([xc + radius * np.sin(angle), yc - radius * np.cos(angle)])


class FieldCircles:
    """The candidate circles of a study's mean soil and the particles along each: the estimate E of a
    realisation's FOS (module doc)."""

    def __init__(self, study):
        circles = [circle for circle in candidate_circles(study, CANDIDATES) if math.isfinite(circle.fos)]
        self.fos = np.array([circle.fos for circle in circles])
        node_xy_m, _ = cloud(study)
        tree = cKDTree(node_xy_m)
        self.along = np.array([tree.query(arc_points_m(circle))[1] for circle in circles], dtype=np.int64).reshape(
            len(circles), ARC_POINTS)

    def estimate(self, study) -> float:
        """E of the study's realisation of its fields (module doc); NaN without circles."""
        if not self.fos.size:
            return math.nan
        node_xy_m, node_spacing_m = cloud(study)
        values = node_properties(study.random_field, study.materials, node_xy_m, node_spacing_m,
                                 assign_materials(study, node_xy_m))
        by_name = {material.name: material for material in study.materials}
        ratio = np.ones(self.fos.size)
        for entry in study.random_field.properties:
            field = values.get(entry.property)
            if field is None:
                continue
            mean, _ = RandomField.moments(entry, by_name[entry.material])
            if entry.property.endswith("_deg"):
                field, mean = np.tan(np.radians(field)), math.tan(math.radians(mean))
            if not mean:
                continue
            along = field[self.along]
            seen = np.isfinite(along).sum(axis=1)
            means = np.where(seen > 0, np.nansum(np.where(np.isfinite(along), along, 0.0), axis=1) / np.maximum(seen, 1),
                             mean)  # a circle outside the field's material: its F unchanged
            ratio *= means / mean
        best = float(np.min(self.fos * ratio))
        return best if math.isfinite(best) else math.nan
