"""A cheap limit-equilibrium search of a study's section: Bishop's simplified method on slip circles,
for ``spfem-fos check`` to say, before anything runs, whether the domain is long enough behind the
crest and beyond the toe for the critical circle (``domain_warnings``).

The section is the study's polygon with its ground extended flat beyond each end that a support
holds by ``EXTENSION_PER_HEIGHT`` slope heights (the ground a longer domain would have; beyond a
free side, a face, no soil), the base y_b its
lowest point: a circle may not pass below it.  The slope is turned to face +x.  The soil is sampled
on a raster of cells ``RASTER_PER_HEIGHT`` per slope height: each cell's material (the study's
regions, the end columns continued outwards), its unit weight (saturated below its piezometric
line) and pore pressure (gamma_w times the depth below that line, or ru times the overburden; a
study with ``[seepage]`` is searched dry).  A circle of centre (xc, yc) and radius R is cut into
``SLICES`` slices between the ground's crossings; slice i of width b_i, weight W_i (its column of
cells), base inclination a_i, pore pressure u_i and the strength c_i, phi_i of the cell at its base
gives (Bishop 1955)

    F = sum_i (c_i b_i + (W_i - u_i b_i) tan(phi_i)) / m_i  /  sum_i W_i sin(a_i),
    m_i = cos(a_i) + sin(a_i) tan(phi_i) / F                 (fixed point from F = 1)

a circle through an elastic material (no strength) is not admissible.  The least F over a grid of
centres and depths is a limit-equilibrium estimate (not a bound: circles, Bishop's assumption), good
to a few per cent: enough to place the critical mechanism, not to replace the strength reduction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from spfem_core.bishop import bishop_circles
from spfem_core.geometry import downslope_sign, relief_m, surface_height_m
from workflows.fos.limit_equilibrium import material_strengths
from workflows.particles import material_rows
from workflows.water.pressure import phreatic_lines, ru_pore_pressure_pa

EXTENSION_PER_HEIGHT = 3.0
RASTER_PER_HEIGHT = 20
SLICES = 40
CENTRES = 16
DEPTHS = 10
POLISHED = 3
MARGIN_PER_HEIGHT = 0.1
"""The domain is short when the critical circle comes closer than this many slope heights to a side."""
NOT_SEEN = ("water.pond", "loads.seismic", "loads.strip", "loads.line", "seepage", "transient")
"""The study fields this search does not take into account (sweep paths start with them): ponded water,
the seismic and surface loads, a computed flow (steady or transient: it is searched dry, or with the
study's piezometric lines).  Cases that differ in them differ in their FOS, not in this estimate."""


@dataclass(frozen=True)
class CriticalCircle:
    fos: float
    centre_m: tuple[float, float]  # in the study's coordinates
    radius_m: float
    entry_x_m: float  # where it leaves the ground at the upper end (study's coordinates)
    exit_x_m: float  # at the lower end
    water: str  # how the pore pressure was taken


def _held_ends(study, polygon: np.ndarray, left_ground_m: float, right_ground_m: float) -> tuple[bool, bool]:
    """Whether a support of the strength reduction holds the polygon's left and right side (the soil
    goes on beyond it: the ground is extended), or the side is free (a face: nothing beyond it)."""
    active = study.strength_reduction.boundary if study.strength_reduction is not None else None
    spacing_m = float(study.geometry.spacing_m)
    base = float(polygon[:, 1].min())
    ends = []
    for x, top in ((float(polygon[:, 0].min()), left_ground_m), (float(polygon[:, 0].max()), right_ground_m)):
        side = np.column_stack([np.full(5, x), base + (top - base) * np.linspace(0.1, 0.9, 5)])
        ends.append(any(boundary.holds(side, spacing_m).any() for boundary in study.boundary
                        if active is None or boundary.name in active))
    return ends[0], ends[1]


class _Section:
    """The raster of the extended section (module doc), turned to face +x."""

    def __init__(self, study, raster_per_height: int = RASTER_PER_HEIGHT):
        polygon = np.asarray(study.geometry.polygon_m, dtype=float)
        self.sign = -1.0 if downslope_sign(polygon) == -1.0 else 1.0
        self.height = relief_m(polygon)
        x_min, x_max = polygon[:, 0].min(), polygon[:, 0].max()
        self.domain = (x_min, x_max)
        self.base = float(polygon[:, 1].min())
        top = float(polygon[:, 1].max())
        self.cell = self.height / raster_per_height
        extension = EXTENSION_PER_HEIGHT * self.height
        xs = np.arange(x_min - extension, x_max + extension + self.cell, self.cell)
        ys = np.arange(self.base + 0.5 * self.cell, top + self.cell, self.cell)
        self.x_study = xs  # raster columns in the study's coordinates
        ground = surface_height_m(polygon, np.clip(xs, x_min, x_max))
        ground = np.where(np.isfinite(ground), ground, self.base)
        held = _held_ends(study, polygon, float(ground[0]), float(ground[-1]))
        outside = ((xs < x_min) & ~held[0]) | ((xs > x_max) & ~held[1])
        self.ground_study = np.where(outside, self.base, ground)  # beyond a free side: no soil
        clipped = np.clip(xs, x_min + 1e-9, x_max - 1e-9)
        grid_x, grid_y = np.meshgrid(clipped, ys)
        points = np.column_stack([grid_x.ravel(), grid_y.ravel()])
        material = material_rows(study, points)
        below_ground = points[:, 1] <= np.repeat(self.ground_study[None, :], ys.size, axis=0).ravel()
        material = np.where(below_ground, material, -1)
        g = float(np.hypot(*study.loads.gravity_m_s2))
        gamma_w = study.water.unit_weight_n_m3 if study.water is not None else 9810.0
        dry = np.array([m.density_kg_m3 for m in study.materials] + [0.0]) * g
        wet = np.array([(m.saturated_density_kg_m3 or m.density_kg_m3) for m in study.materials] + [0.0]) * g
        pore = np.zeros(points.shape[0])
        saturated = np.zeros(points.shape[0], dtype=bool)
        self.water = "dry"
        if study.seepage is not None:
            self.water = "dry (the seepage of [seepage] is not solved for this estimate)"
        elif study.transient is not None:
            self.water = "dry (the flow of [transient] and its suction are not solved for this estimate)"
        else:
            lines, line_of = phreatic_lines(study, np.maximum(material, 0))
            for i, line in enumerate(lines):
                on = (line_of == i) & (material >= 0)
                level = np.interp(points[on, 0], line[:, 0], line[:, 1])
                saturated[on] = points[on, 1] <= level
                pore[on] = gamma_w * np.maximum(level - points[on, 1], 0.0)
            if lines:
                self.water = "with the piezometric lines"
            if study.water is not None and study.water.ru is not None:
                inside = material >= 0
                pore[inside] = ru_pore_pressure_pa(study, points[inside], lambda p: material_rows(study, p), g)
                self.water = f"with ru = {study.water.ru:g}"
        self.unit_weight = np.where(saturated, wet[material], dry[material]).reshape(grid_x.shape)
        self.cumulative = np.ascontiguousarray(np.vstack([np.zeros((1, xs.size)), np.cumsum(self.unit_weight, axis=0)]))
        self.pore = np.ascontiguousarray(pore.reshape(grid_x.shape), dtype=float)
        self.material = np.ascontiguousarray(material.reshape(grid_x.shape), dtype=np.int64)
        cohesion, tan_phi = material_strengths(study.materials)  # c = inf: no strength (elastic)
        self.cohesion = np.append(cohesion, 0.0).astype(float)  # (the last: no soil, material -1)
        self.tan_phi = np.append(tan_phi, 0.0).astype(float)
        # the searched section faces +x: x' = sign x
        order = np.argsort(self.sign * xs)
        self.x = np.ascontiguousarray((self.sign * xs)[order], dtype=float)
        self.ground = np.ascontiguousarray(self.ground_study[order], dtype=float)
        self.void = np.ascontiguousarray(outside[order])  # beyond a free side: no soil, not even below the base
        self.columns = np.ascontiguousarray(order, dtype=np.int64)


def _bishop_many(section: _Section, xc, yc, radius) -> np.ndarray:
    """(k, 3): F (inf: not admissible), entry and exit x of each circle, in the searched coordinates
    (``spfem_core.bishop``, compiled: the quick search of a study's window evaluates about 800 circles)."""
    return bishop_circles(np.asarray(xc, float).reshape(-1), np.asarray(yc, float).reshape(-1),
                          np.asarray(radius, float).reshape(-1), section.x, section.ground, section.void,
                          section.base, section.cell, section.columns, section.cumulative, section.material,
                          section.pore, section.cohesion, section.tan_phi, SLICES)


def _bishop(section: _Section, xc: float, yc: float, radius: float) -> tuple[float, float, float]:
    """(F, entry x, exit x) of one circle in the searched coordinates (F = inf: not admissible)."""
    fos, left, right = _bishop_many(section, xc, yc, radius)[0]
    return float(fos), float(left), float(right)


QUICK = dict(raster_per_height=10, centres=10, depths=6, polished=1)
"""The coarser search of ``quick``: F within about 1% of the full one, in a tenth of its time (the
window of a FOS search, ``fos.prediction``)."""


def _grid(section: _Section, centres: int, depths: int) -> list[tuple[float, float, float, float]]:
    """(F, xc, yc, R) of every admissible circle of the grid search (module doc), searched coordinates."""
    h = section.height
    toe_y, top_y = float(section.ground.min()), float(section.ground.max())
    sloping = section.x[(section.ground > toe_y + 0.02 * h) & (section.ground < top_y - 0.02 * h)]
    if not sloping.size:  # a vertical face between two raster columns: the columns of the steepest step
        step = int(np.argmax(np.abs(np.diff(section.ground))))
        sloping = section.x[step:step + 2]
    x_low, x_high = sloping.min(), sloping.max()
    circles = []
    for xc in np.linspace(x_low - h, x_high + h, centres):
        for yc in np.linspace(toe_y + 0.3 * h, top_y + 2.0 * h, centres):
            radii = [yc - bottom for bottom in np.linspace(section.base, toe_y + 0.3 * h, depths)]
            radii.append(math.hypot(xc - x_high, yc - toe_y))  # the toe circle (a steep face's lowest point is beyond the toe)
            circles += [(xc, yc, radius) for radius in radii if radius > 0.0]
    if not circles:
        return []
    xc, yc, radius = np.array(circles, dtype=float).T
    fos = _bishop_many(section, xc, yc, radius)[:, 0]
    return [(float(f), float(a), float(b), float(c)) for f, a, b, c in zip(fos, xc, yc, radius) if math.isfinite(f)]


def _circle(section: _Section, xc: float, yc: float, radius: float) -> CriticalCircle:
    fos, left, right = _bishop(section, xc, yc, radius)
    sign = section.sign
    return CriticalCircle(float(fos), (float(sign * xc), float(yc)), float(radius), float(sign * left),
                          float(sign * right), section.water)


def critical_circle(study, quick: bool = False) -> CriticalCircle | None:
    """The least Bishop F over a grid of circles, the best ``POLISHED`` of them polished by
    Nelder-Mead (module doc; ``quick``: the coarser search ``QUICK``); None where no circle is
    admissible."""

    search = QUICK if quick else dict(raster_per_height=RASTER_PER_HEIGHT, centres=CENTRES, depths=DEPTHS,
                                      polished=POLISHED)
    section = _Section(study, search["raster_per_height"])
    found = _grid(section, search["centres"], search["depths"])
    if not found:
        return None
    best = (math.inf, 0.0, 0.0, 0.0)
    for start in sorted(found)[:search["polished"]]:
        polished = minimize(lambda p: _bishop(section, *p)[0], np.array(start[1:]), method="Nelder-Mead",
                            options={"xatol": 1e-3 * section.height, "fatol": 1e-6, "maxiter": 300})
        candidate = (float(polished.fun), *polished.x) if polished.fun <= start[0] else start
        best = min(best, candidate)
    return _circle(section, *best[1:])


def candidate_circles(study, count: int = 40) -> list[CriticalCircle]:
    """The ``count`` least circles of the quick grid search (``QUICK``), least first: where the mechanism
    of a soil that varies from point to point may run (``probabilistic.field_mechanisms.field_estimate``)."""
    section = _Section(study, QUICK["raster_per_height"])
    return [_circle(section, xc, yc, radius) for _, xc, yc, radius in sorted(_grid(section, 16, 8))[:count]]


def domain_warnings(study, circle: CriticalCircle | None = None) -> list[str]:
    """A warning for each side of the domain that the critical ``circle`` (default: searched here)
    reaches or comes within ``MARGIN_PER_HEIGHT`` slope heights of (module doc): the strength
    reduction's mechanism would meet that side, and the FOS would depend on where it was drawn."""
    circle = circle or critical_circle(study)
    if circle is None:
        return []
    polygon = np.asarray(study.geometry.polygon_m, dtype=float)
    x_min, x_max = polygon[:, 0].min(), polygon[:, 0].max()
    margin = MARGIN_PER_HEIGHT * relief_m(polygon)
    crest_left = downslope_sign(polygon) != -1.0
    warnings = []
    low, high = sorted((circle.entry_x_m, circle.exit_x_m))
    for side_x, reach, is_left in ((x_min, low, True), (x_max, high, False)):
        short = (reach - side_x < margin) if is_left else (side_x - reach < margin)
        if not short:
            continue
        where = "behind the crest" if is_left == crest_left else "beyond the toe"
        need = (side_x - (reach - margin)) if is_left else ((reach + margin) - side_x)
        warnings.append(
            f"warning: the domain may be too short {where}: the critical circle of a limit-equilibrium search "
            f"(Bishop, {circle.water}: F = {circle.fos:.3g}) reaches x = {reach:.4g} m, "
            f"{'beyond' if (reach < side_x if is_left else reach > side_x) else 'within ' + format(margin, '.3g') + ' m of'}"
            f" the side x = {side_x:.4g} m; extend the domain {where} by at least {max(need, 0.0):.3g} m, or the FOS "
            "may be decided by that side"
        )
    return warnings
