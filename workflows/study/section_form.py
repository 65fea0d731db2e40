"""A section drawn as lines (``[geometry.section]``): the polygon, the materials' regions and the
supports it makes.

The ground line g_0 ... g_n (x increasing) and the base level y_b close into the polygon

    (x_0, y_b), (x_n, y_b), g_n, g_(n-1), ..., g_0.

A layer's lines close into its material's region over the x-range they cover:

- ``below_m`` L only: L, then down to 1 m below both the base and L's lowest point, at its ends;
- ``above_m`` L only: L, then up to 1 m above both the ground's top and L's highest point;
- both: ``below_m`` (the upper line) clipped to the x-range where it lies above ``above_m`` (the
  lower line), then the lower line back along it; where the two lines meet at an end, the point
  once.  Lines may meet (a lens pinching out at its ends, or running on together beyond it); a
  layer whose lines meet and part again would be two regions, and is refused (give each part a
  material of its own).

The regions may reach outside the section (a line may dip under the base): the polygon clips
them, as every region_m.  A problem with a region a layer makes names the layer
(``geometry.section.layers[i]``), the field the study wrote.  A study
that gives no ``[[boundary]]`` gets a fixed base (``base``: y <= y_b, vx = vy = 0) and rollers on
both sides (``left``: x <= x_0, ``right``: x >= x_n, vx = 0).
"""

from __future__ import annotations

import numpy as np

from spfem_core.geometry import polygon_problem, size_m
from workflows.fields import StudyError
from workflows.study.geometry import SectionForm, SectionLayer


def polygon_m(form: SectionForm) -> list[list[float]]:
    """The outline of the section (module doc)."""
    ground = [list(point) for point in form.ground_m]
    return [[ground[0][0], form.base_y_m], [ground[-1][0], form.base_y_m], *ground[::-1]]


def supports(form: SectionForm) -> list[dict]:
    """``[[boundary]]`` entries: a fixed base and a roller on each side."""
    return [
        {"name": "base", "y_max_m": form.base_y_m, "vx_m_s": 0.0, "vy_m_s": 0.0},
        {"name": "left", "x_max_m": form.ground_m[0][0], "vx_m_s": 0.0},
        {"name": "right", "x_min_m": form.ground_m[-1][0], "vx_m_s": 0.0},
    ]


def _clipped(line, low_m: float, high_m: float) -> list[list[float]]:
    """The points of ``line`` within [low, high], with the line's points at low and high."""
    xy = np.array(line, dtype=float)
    inside = [list(p) for p in xy if low_m < p[0] < high_m]
    ends = [[x, float(np.interp(x, xy[:, 0], xy[:, 1]))] for x in (low_m, high_m)]
    return [ends[0], *inside, ends[1]]


MEET_TOLERANCE = 1e-9
"""Two lines meet where they are closer than this fraction of the section's size."""


def _apart_ranges(upper, lower, low_m: float, high_m: float, tol_m: float) -> list[tuple[float, float]]:
    """The x-ranges within [low, high] where the line ``upper`` lies more than ``tol_m`` above ``lower``
    (both piecewise linear: their difference is linear between their vertices)."""
    upper, lower = np.array(upper, dtype=float), np.array(lower, dtype=float)
    xs = np.array(sorted({low_m, high_m, *(x for x in (*upper[:, 0], *lower[:, 0]) if low_m < x < high_m)}))
    apart = np.interp(xs, *upper.T) - np.interp(xs, *lower.T) > tol_m
    ranges: list[tuple[float, float]] = []
    for i in np.flatnonzero(apart[:-1] | apart[1:]):
        if ranges and ranges[-1][1] == xs[i] and apart[i]:  # not where the lines meet
            ranges[-1] = (ranges[-1][0], float(xs[i + 1]))
        else:
            ranges.append((float(xs[i]), float(xs[i + 1])))
    return ranges


def layer_region(form: SectionForm, layer: SectionLayer, field: str) -> list[list[float]]:
    """The region of one layer (module doc); StudyError on ``field`` (the layer) when its lines meet
    and part again, or never part."""
    if layer.above_m is None or layer.below_m is None:
        line = [list(p) for p in (layer.above_m or layer.below_m)]
        if layer.below_m is None:
            beyond = max(max(y for _, y in form.ground_m), max(y for _, y in line)) + 1.0
        else:
            beyond = min(form.base_y_m, min(y for _, y in line)) - 1.0
        return [*line, [line[-1][0], beyond], [line[0][0], beyond]]
    low = max(layer.above_m[0][0], layer.below_m[0][0])
    high = min(layer.above_m[-1][0], layer.below_m[-1][0])
    tol_m = MEET_TOLERANCE * size_m([*form.ground_m, *layer.above_m, *layer.below_m])
    ranges = _apart_ranges(layer.below_m, layer.above_m, low, high, tol_m)
    if len(ranges) != 1:
        meets = ", ".join(f"{b:g}" for (_, b), _ in zip(ranges, ranges[1:]))
        raise StudyError(field, "below_m and above_m coincide wherever they share x: the layer has no thickness"
                         if not ranges else f"below_m and above_m meet at x = {meets} m and part again: the layer "
                         f"would be {len(ranges)} separate regions, and a material has one; give each part a "
                         "material (and a layer) of its own")
    (low, high), = ranges
    upper, lower = _clipped(layer.below_m, low, high), _clipped(layer.above_m, low, high)[::-1]
    if abs(lower[0][1] - upper[-1][1]) <= tol_m:  # the lines meet at the right end
        lower = lower[1:]
    if lower and abs(lower[-1][1] - upper[0][1]) <= tol_m:  # and at the left end
        lower = lower[:-1]
    return [*upper, *lower]


def expand(raw: dict, form: SectionForm) -> dict:
    """The study dict ``raw`` with what ``form`` makes filled in (module doc); ``raw`` is not changed."""
    geometry = dict(raw.get("geometry", {}))
    for other in ("polygon_m", "slope"):
        if other in geometry:
            raise StudyError(f"geometry.{other}", f"give {other} or [geometry.section], not both")
    geometry["polygon_m"] = polygon_m(form)
    expanded = dict(raw, geometry=geometry)
    if "boundary" not in raw:
        expanded["boundary"] = supports(form)
    materials = [dict(m) if isinstance(m, dict) else m for m in raw.get("materials", [])]
    names = [m.get("name") for m in materials if isinstance(m, dict)]
    for i, layer in enumerate(form.layers):
        field = f"geometry.section.layers[{i}].material"
        if layer.material not in names:
            raise StudyError(field, f"no [[materials]] named {layer.material!r} (known: {names})")
        material = materials[names.index(layer.material)]
        if "region_m" in material:
            raise StudyError(field, f"{layer.material!r} gives region_m: place a material by its region or by "
                             "its lines, not both")
        region = layer_region(form, layer, f"geometry.section.layers[{i}]")
        problem = polygon_problem(region)
        if problem:
            raise StudyError(f"geometry.section.layers[{i}]", f"the region its lines close {problem}")
        material["region_m"] = region
    expanded["materials"] = materials
    return expanded
