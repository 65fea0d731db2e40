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
        self.cumulative = np.vstack([np.zeros((1, xs.size)), np.cumsum(self.unit_weight, axis=0)])
        self.pore = pore.reshape(grid_x.shape)
        self.material = material.reshape(grid_x.shape)
        cohesion, tan_phi = material_strengths(study.materials)  # c = inf: no strength (elastic)
        self.cohesion = np.append(cohesion, 0.0)
        self.tan_phi = np.append(tan_phi, 0.0)
        self.ys = ys
        # the searched section faces +x: x' = sign x
        order = np.argsort(self.sign * xs)
        self.x = (self.sign * xs)[order]
        self.ground = self.ground_study[order]
        self.void = outside[order]  # beyond a free side: no soil, not even below the base
        self.ground_list = self.ground.tolist()  # (for scalar look-ups)
        self.columns = order

    def ground_at(self, x):
        """The ground's height at the searched abscissae x; -inf beyond a free side (a circle there is
        in the air, whatever its depth)."""
        last = self.x.size - 1
        if np.ndim(x) == 0:  # (the crossings' bisection: scalars, many)
            position = min(max((x - self.x[0]) / self.cell, 0.0), float(last))
            if self.void[int(position + 0.5)]:
                return -math.inf
            left = min(int(position), last - 1)
            return self.ground_list[left] + (self.ground_list[left + 1] - self.ground_list[left]) * (position - left)
        columns = np.clip(np.rint((x - self.x[0]) / self.cell).astype(np.int64), 0, last)
        return np.where(self.void[columns], -np.inf, np.interp(x, self.x, self.ground))

    def column(self, x) -> np.ndarray:
        """Raster column index of the searched abscissae x."""
        index = np.clip(np.rint((x - self.x[0]) / self.cell).astype(np.int64), 0, self.x.size - 1)
        return self.columns[index]

    def row(self, y) -> np.ndarray:
        return np.clip(np.floor((y - self.base) / self.cell).astype(np.int64), 0, self.ys.size - 1)


CROSSING_BISECTIONS = 26
"""Bisections of the interval (at most a raster cell) in which an arc meets the ground: 1e-8 of a cell."""


def _bishop(section: _Section, xc: float, yc: float, radius: float) -> tuple[float, float, float]:
    """(F, entry x, exit x) of one circle in the searched coordinates (F = inf: not admissible)."""
    x = section.x
    if max(section.ground_at(xc - radius), section.ground_at(xc + radius)) > yc:
        return math.inf, math.nan, math.nan  # the circle meets the ground on its upper half: no closed block
    inside = (x > xc - radius) & (x < xc + radius)
    if not inside.any():
        return math.inf, math.nan, math.nan
    base_y = yc - np.sqrt(np.maximum(radius**2 - (x - xc) ** 2, 0.0))
    cut = inside & (base_y < section.ground - 1e-9) & ~section.void
    if cut.sum() < 3:
        return math.inf, math.nan, math.nan
    index = np.flatnonzero(cut)
    if index[-1] - index[0] + 1 != index.size:  # the circle leaves and re-enters the ground
        return math.inf, math.nan, math.nan
    def crossing(outside: float, inside: float) -> float:
        """Where the arc meets the ground between an abscissa outside the ground and one inside it."""
        for _ in range(CROSSING_BISECTIONS):
            middle = 0.5 * (outside + inside)
            depth = section.ground_at(middle) - (yc - math.sqrt(max(radius**2 - (middle - xc) ** 2, 0.0)))
            outside, inside = (middle, inside) if depth <= 0.0 else (outside, middle)
        return 0.5 * (outside + inside)

    left = crossing(max(x[index[0] - 1], xc - radius) if index[0] > 0 else xc - radius, x[index[0]])
    right = crossing(min(x[index[-1] + 1], xc + radius) if index[-1] + 1 < x.size else xc + radius, x[index[-1]])
    edges = np.linspace(left, right, SLICES + 1)
    middle = 0.5 * (edges[1:] + edges[:-1])
    width = np.diff(edges)
    base = yc - np.sqrt(np.maximum(radius**2 - (middle - xc) ** 2, 0.0))
    if base.min() < section.base - 1e-9:
        return math.inf, math.nan, math.nan
    ground = section.ground_at(middle)
    column = section.column(middle)
    rows = section.row(base)
    tops = np.maximum(section.row(ground - 0.5 * section.cell), rows)  # the last cell whose centre is in the ground
    # the mean unit weight of each column of cells from the base to the ground
    weight = (section.cumulative[tops + 1, column] - section.cumulative[rows, column]) / (tops - rows + 1) * (
        ground - base) * width
    material = section.material[rows, column]
    cohesion, tan_phi = section.cohesion[material], section.tan_phi[material]
    if not np.all(np.isfinite(cohesion)):
        return math.inf, math.nan, math.nan
    pore = section.pore[rows, column]
    alpha = np.arctan2(xc - middle, np.sqrt(np.maximum(radius**2 - (middle - xc) ** 2, 1e-12)))
    driving = float(np.sum(weight * np.sin(alpha)))
    if driving <= 0.0:
        return math.inf, math.nan, math.nan
    resisting_base = cohesion * width + np.maximum(weight - pore * width, 0.0) * tan_phi
    fos = 1.0
    for _ in range(60):
        m = np.cos(alpha) + np.sin(alpha) * tan_phi / fos
        if np.any(m <= 0.2):
            return math.inf, math.nan, math.nan
        new = float(np.sum(resisting_base / m)) / driving
        if abs(new - fos) < 1e-7:
            fos = new
            break
        fos = new
    return fos, left, right


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
    found = []
    for xc in np.linspace(x_low - h, x_high + h, centres):
        for yc in np.linspace(toe_y + 0.3 * h, top_y + 2.0 * h, centres):
            radii = [yc - bottom for bottom in np.linspace(section.base, toe_y + 0.3 * h, depths)]
            radii.append(math.hypot(xc - x_high, yc - toe_y))  # the toe circle (a steep face's lowest point is beyond the toe)
            for radius in radii:
                if radius > 0.0:
                    fos = _bishop(section, xc, yc, radius)[0]
                    if math.isfinite(fos):
                        found.append((fos, xc, yc, radius))
    return found


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
