"""A slope from its dimensions (``[geometry.slope]``): the polygon, supports, monitors and layers it makes.

Coordinates: the fixed base at y = 0, the crest on the left.  With H the height, D the
foundation depth, run = H / tan(angle) (or gradient H), crest and toe lengths Lc and Lt:

    x_crest = Lc,  x_toe = Lc + run,  width W = x_toe + Lt  (W = x_toe when D = 0)
    polygon  (0, 0), (W, 0), (W, D), (x_toe, D), (x_crest, D + H), (0, D + H)
             (D = 0: the slope stands on the base, (0, 0), (x_toe, 0), (x_crest, H), (0, H))

A study that gives no ``[[boundary]]`` gets a firm rough base (``base``: y <= 0, vy = 0, the soil
sliding along it at its own strength, ``slip = "soil"``) and rollers on the
sides (``left``: x <= 0, and with a foundation ``right``: x >= W; D = 0 leaves the face free); one that gives no ``[[monitors]]`` gets ``crest``
and ``toe``.  With ``layer_depths_m`` = [d1, d2, ...], layer k lies between depths d_(k-1) and
d_k below the crest (d_0 = 0, the last down to the base): the materials without ``region_m``
take the layers from the top, in file order.
"""

from __future__ import annotations

from workflows.fields import StudyError
from workflows.study.geometry import SlopeForm


def polygon_m(form: SlopeForm) -> list[list[float]]:
    """The outline of the slope (module doc)."""
    h, d = form.height_m, form.foundation_depth
    x_crest = form.crest_length
    x_toe = x_crest + form.run_m
    if d == 0.0:
        return [[0.0, 0.0], [x_toe, 0.0], [x_crest, h], [0.0, h]]
    width = x_toe + form.toe_length
    return [[0.0, 0.0], [width, 0.0], [width, d], [x_toe, d], [x_crest, d + h], [0.0, d + h]]


def supports(form: SlopeForm) -> list[dict]:
    """``[[boundary]]`` entries: a firm rough base (held vertically, the soil sliding along it at its
    own strength: ``slip = "soil"``), a roller behind the crest and, with a foundation, one at its
    far end (without one, x = W is the toe of the face, which must stay free)."""
    width = max(x for x, _ in polygon_m(form))
    entries = [
        {"name": "base", "y_max_m": 0.0, "vy_m_s": 0.0, "slip": "soil"},
        {"name": "left", "x_max_m": 0.0, "vx_m_s": 0.0},
    ]
    if form.foundation_depth > 0.0:
        entries.append({"name": "right", "x_min_m": width, "vx_m_s": 0.0})
    return entries


def monitors(form: SlopeForm) -> list[dict]:
    """``[[monitors]]`` entries at the crest and at the toe."""
    d = form.foundation_depth
    x_crest = form.crest_length
    return [
        {"name": "crest", "x_m": x_crest, "y_m": d + form.height_m},
        {"name": "toe", "x_m": x_crest + form.run_m, "y_m": d},
    ]


def layer_regions(form: SlopeForm) -> list[list[list[float]]]:
    """One rectangle per layer, from the top (they cover the whole width; the polygon clips them)."""
    top = form.foundation_depth + form.height_m
    width = max(x for x, _ in polygon_m(form)) + 1.0
    levels = [top + 1.0] + [top - depth for depth in form.layer_depths_m] + [-1.0]
    return [[[-1.0, low], [width, low], [width, high], [-1.0, high]] for high, low in zip(levels, levels[1:])]


def expand(raw: dict, form: SlopeForm) -> dict:
    """The study dict ``raw`` with what ``form`` makes filled in (module doc); ``raw`` is not changed."""
    geometry = dict(raw.get("geometry", {}))
    if "polygon_m" in geometry:
        raise StudyError("geometry.polygon_m", "give polygon_m or [geometry.slope], not both")
    geometry["polygon_m"] = polygon_m(form)
    expanded = dict(raw, geometry=geometry)
    if "boundary" not in raw:
        expanded["boundary"] = supports(form)
    if "monitors" not in raw:
        expanded["monitors"] = monitors(form)
    if form.layer_depths_m:
        materials = [dict(m) for m in raw.get("materials", []) if isinstance(m, dict)]
        layered = [m for m in materials if "region_m" not in m]
        regions = layer_regions(form)
        if len(layered) != len(regions):
            raise StudyError("geometry.slope.layer_depths_m", f"makes {len(regions)} layers, for {len(layered)} "
                             "materials without region_m")
        for material, region in zip(layered, regions):
            material["region_m"] = region
        expanded["materials"] = materials
    return expanded
