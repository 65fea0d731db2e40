"""The length and time scales of a slope, from its study: what "moved a lot" and "a while" mean.

- **Slope height** H (:func:`slope_height_m`): the relief of the free surface, the highest
  minus the lowest point of the polygon's upper boundary (crest above toe).  The foundation
  below the toe does not count: a 10 m slope on a 5 m or a 10 m foundation has H = 10 m.
  ``strength_reduction.slope_height_m`` overrides it.
- **Response time** T (:func:`response_time_s`): the fundamental period of a soil layer as
  thick as the domain on a rigid base, T = 4 H_domain / V_s, with the shear-wave speed
  V_s = sqrt(G / rho) of the softest material: the time a disturbance takes to cross the
  slope and come back, twice.
"""

from __future__ import annotations

import math

from workflows.study import Study, StudyError


def upper_boundary_heights(polygon_m) -> list[float]:
    """Heights of the polygon's upper boundary y_top(x), the largest y of the boundary at x, at
    every vertex abscissa, approached from the left and from the right (where y_top, piecewise
    linear with jumps at vertical edges, takes its extreme values)."""
    vertices = list(polygon_m)
    edges = [(a, b) if a[0] <= b[0] else (b, a) for a, b in zip(vertices, vertices[1:] + vertices[:1])]
    heights = []
    for x0 in sorted({x for x, _ in vertices}):
        left, right = [], []
        for (x1, y1), (x2, y2) in edges:
            if x1 == x2 or not x1 <= x0 <= x2:
                continue  # vertical edges are seen through their neighbours
            y = y1 if x0 == x1 else y2 if x0 == x2 else y1 + (x0 - x1) * (y2 - y1) / (x2 - x1)
            if x1 < x0:
                left.append(y)
            if x2 > x0:
                right.append(y)
        heights += [max(side) for side in (left, right) if side]
    return heights


def slope_height_m(study: Study) -> float:
    """H: ``strength_reduction.slope_height_m`` if given, else the relief of the free surface
    (module doc); the domain's height when the upper boundary is flat (no slope)."""
    stage = study.strength_reduction
    if stage is not None and stage.slope_height_m is not None:
        return stage.slope_height_m
    heights = upper_boundary_heights(study.geometry.polygon_m)
    relief = max(heights) - min(heights) if heights else 0.0
    if relief > 0.0:
        return relief
    ys = [y for _, y in study.geometry.polygon_m]
    return max(ys) - min(ys)


MIN_SPACINGS_PER_HEIGHT = 4
"""A strength-reduction study needs at least this many particle spacings over the slope height."""


def check_resolution(study: Study) -> None:
    """StudyError on ``geometry.spacing_m`` when the slope height spans fewer than
    ``MIN_SPACINGS_PER_HEIGHT`` spacings (no mechanism can form across a handful of particles)."""
    height = slope_height_m(study)
    if height < MIN_SPACINGS_PER_HEIGHT * study.geometry.spacing_m:
        raise StudyError(
            "geometry.spacing_m",
            f"{study.geometry.spacing_m:g} m: the slope height {height:g} m spans fewer than "
            f"{MIN_SPACINGS_PER_HEIGHT} spacings; make it at most {height / MIN_SPACINGS_PER_HEIGHT:g} m "
            "(10 or more spacings give an FOS within a few per cent, docs/verification.md)",
        )


def response_time_s(study: Study) -> float:
    """T = 4 H_domain / V_s, V_s = sqrt(G / rho) of the softest material (module doc)."""
    ys = [y for _, y in study.geometry.polygon_m]
    speed = min(
        math.sqrt(m.youngs_modulus_pa / (2.0 * (1.0 + m.poisson_ratio)) / m.density_kg_m3) for m in study.materials
    )
    return 4.0 * (max(ys) - min(ys)) / speed
