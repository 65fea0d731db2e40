"""A section drawn as lines (``[geometry.section]``): the polygon, the materials' regions and the
supports it makes.

The ground line g_0 ... g_n (x increasing) and the base level y_b close into the polygon

    (x_0, y_b), (x_n, y_b), g_n, g_(n-1), ..., g_0.

A layer's lines close into its material's region over the x-range they cover:

- ``below_m`` L only: L, then down to y_b - 1 at its ends;
- ``above_m`` L only: L, then up to the ground's top + 1 at its ends;
- both: ``below_m`` (the upper line) clipped to the x-range the two share, then ``above_m`` (the
  lower line) back along it; where the two lines meet at an end, the point once.

The regions may reach outside the section: the polygon clips them, as every region_m.  A study
that gives no ``[[boundary]]`` gets a fixed base (``base``: y <= y_b, vx = vy = 0) and rollers on
both sides (``left``: x <= x_0, ``right``: x >= x_n, vx = 0).
"""

from __future__ import annotations

import numpy as np

from workflows.fields import StudyError
from workflows.study.tables import SectionForm, SectionLayer


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


def layer_region(form: SectionForm, layer: SectionLayer) -> list[list[float]]:
    """The region of one layer (module doc)."""
    if layer.above_m is None or layer.below_m is None:
        line = [list(p) for p in (layer.above_m or layer.below_m)]
        beyond = (max(y for _, y in form.ground_m) + 1.0) if layer.below_m is None else form.base_y_m - 1.0
        return [*line, [line[-1][0], beyond], [line[0][0], beyond]]
    low = max(layer.above_m[0][0], layer.below_m[0][0])
    high = min(layer.above_m[-1][0], layer.below_m[-1][0])
    upper, lower = _clipped(layer.below_m, low, high), _clipped(layer.above_m, low, high)[::-1]
    if lower[0] == upper[-1]:  # the lines meet at the right end
        lower = lower[1:]
    if lower and lower[-1] == upper[0]:  # and at the left end
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
        material["region_m"] = layer_region(form, layer)
    expanded["materials"] = materials
    return expanded
