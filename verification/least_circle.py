"""The least slip circle of an undrained (phi = 0) slope: a rigorous upper bound on its FOS.

    python -m verification.least_circle --height 5 --angle 45 --cu 20e3 --unit-weight 20e3 [--foundation-depth 0]

A circle of centre (xc, yc) and radius R cuts the soil polygon into a block that can turn about
the centre as a rigid body, the rest at rest.  For phi = 0 the work balance of that mechanism is

    F = cu R L / (gamma |A (x_bar - xc)|)

with L the length of the arc inside the soil, A the block's area and x_bar its centroid: the
strength reduced by F dissipates exactly the work of gravity, so the collapse SRF of the slope is
at most F (the kinematic theorem of plasticity), for every admissible circle.  A circle is
admissible when it does not cut a support: the fixed base (y = 0) and the roller side behind the
crest (x = 0) stay at least R from the centre, so the block moves away from them.

The soil lies below a ground profile y = ground(x) and above the base y = 0; the block's area
and first moment are integrated in x (midpoint rule, ``INTEGRATION_POINTS``), L on as many
points of the circle.  The least F is searched on a grid of centres (R minimised for each by a
bounded scalar search, at ``SEARCH_POINTS``), then polished by Nelder-Mead.  Checked against Taylor's (1937) toe circles in
``tests/test_least_circle.py``.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize, minimize_scalar

from workflows.study.geometry import SlopeForm
from workflows.study.slope_form import polygon_m

INTEGRATION_POINTS = 20000
"""Midpoints in x and on the arc of the final circle."""
SEARCH_POINTS = 1000
"""The same, on the grid of centres that finds the start."""


@dataclass(frozen=True)
class Circle:
    xc_m: float
    yc_m: float
    radius_m: float
    fos: float


def slope_polygon_m(height_m: float, angle_deg: float, foundation_depth_m: float = 0.0,
                    crest_length_m: float | None = None, toe_length_m: float | None = None) -> np.ndarray:
    """The outline that ``[geometry.slope]`` makes (``workflows.study.slope_form.polygon_m``), counter-clockwise."""
    form = SlopeForm(height_m=height_m, angle_deg=angle_deg, foundation_depth_m=foundation_depth_m,
                     crest_length_m=crest_length_m, toe_length_m=toe_length_m)
    return np.array(polygon_m(form))


def _distance_to_segment(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = np.clip(np.dot(point - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(point - (a + t * (b - a))))


class LeastCircle:
    """phi = 0 circles in the soil 0 < x < W, 0 < y < ground(x), with fixed supports (module doc)."""

    def __init__(self, ground_x_m, ground_y_m, cu_pa: float, unit_weight_n_m3: float,
                 supports: list[tuple[tuple[float, float], tuple[float, float]]]):
        self.ground_x = np.asarray(ground_x_m, float)
        self.ground_y = np.asarray(ground_y_m, float)
        self.width = float(self.ground_x[-1])
        self.cu, self.gamma = cu_pa, unit_weight_n_m3
        self.supports = [(np.array(a, float), np.array(b, float)) for a, b in supports]
        self.resolution(INTEGRATION_POINTS)

    def resolution(self, points: int) -> None:
        """Integrate each circle on ``points`` midpoints in x and on the arc."""
        self._s = (np.arange(points) + 0.5) / points  # midpoints on [0, 1]
        self._theta = 2.0 * math.pi * self._s

    def max_radius(self, xc: float, yc: float) -> float:
        """The largest admissible R about (xc, yc): the distance to the nearest support."""
        centre = np.array([xc, yc])
        return min(_distance_to_segment(centre, a, b) for a, b in self.supports)

    def fos(self, xc: float, yc: float, radius: float) -> float:
        """F of one circle; inf where it cuts no block or a support."""
        if radius <= 0.0 or radius > self.max_radius(xc, yc) * (1.0 + 1e-9):
            return math.inf
        x_lo, x_hi = max(xc - radius, 0.0), min(xc + radius, self.width)
        if x_hi <= x_lo:
            return math.inf
        x = x_lo + (x_hi - x_lo) * self._s
        half = np.sqrt(np.maximum(radius * radius - (x - xc) ** 2, 0.0))
        ground = np.interp(x, self.ground_x, self.ground_y)
        thickness = np.maximum(np.minimum(ground, yc + half) - np.maximum(yc - half, 0.0), 0.0)
        dx = (x_hi - x_lo) / len(self._s)
        area = thickness.sum() * dx
        if area <= 0.0:
            return math.inf
        driving = self.gamma * abs((thickness * (x - xc)).sum() * dx)
        ax, ay = xc + radius * np.cos(self._theta), yc + radius * np.sin(self._theta)
        inside = (ax > 0.0) & (ax < self.width) & (ay > 0.0) & (ay < np.interp(ax, self.ground_x, self.ground_y))
        arc_length = inside.mean() * 2.0 * math.pi * radius
        return math.inf if driving <= 0.0 else self.cu * radius * arc_length / driving

    def _best_radius(self, xc: float, yc: float) -> tuple[float, float]:
        r_max = self.max_radius(xc, yc)
        if r_max <= 0.0:
            return math.inf, 0.0
        done = minimize_scalar(lambda r: min(self.fos(xc, yc, r), 1e30), bounds=(0.02 * r_max, r_max),
                               method="bounded", options={"xatol": 1e-6 * r_max})
        # The least circle often touches a support: try R at its bound too.
        at_bound = self.fos(xc, yc, r_max)
        return (done.fun, done.x) if done.fun <= at_bound else (at_bound, r_max)

    def search(self, n_grid: int = 24) -> Circle:
        """The least circle (module doc)."""
        top = float(self.ground_y.max())
        size = max(self.width, top)
        best = (math.inf, 0.0, 0.0)
        self.resolution(SEARCH_POINTS)
        for xc in np.linspace(0.0, self.width + 0.5 * size, n_grid):
            for yc in np.linspace(0.05 * top, top + 1.5 * size, n_grid):
                f, _ = self._best_radius(xc, yc)
                if f < best[0]:
                    best = (f, xc, yc)
        self.resolution(INTEGRATION_POINTS)
        polished = minimize(lambda c: min(self._best_radius(c[0], c[1])[0], 1e30), [best[1], best[2]],
                            method="Nelder-Mead", options={"xatol": 1e-6 * size, "fatol": 1e-8})
        f, radius = self._best_radius(*polished.x)
        return Circle(float(polished.x[0]), float(polished.x[1]), float(radius), float(f))


def slope_least_circle(height_m: float, angle_deg: float, cu_pa: float, unit_weight_n_m3: float,
                       foundation_depth_m: float = 0.0) -> Circle:
    """The least circle of a ``[geometry.slope]`` slope with its default supports: the fixed base
    y = 0 under the whole width, the roller x = 0 behind the crest and, with a foundation, the
    roller at its far end."""
    polygon = slope_polygon_m(height_m, angle_deg, foundation_depth_m)
    top = polygon[:, 1].max()
    # The ground surface from behind the crest to the far end: the polygon's top, walked backwards.
    surface = (polygon[polygon[:, 1] > 0.0] if foundation_depth_m > 0.0 else polygon[1:])[::-1]
    width = surface[-1, 0]
    supports = [((0.0, 0.0), (width, 0.0)), ((0.0, 0.0), (0.0, top))]
    if foundation_depth_m > 0.0:
        supports.append(((width, 0.0), (width, foundation_depth_m)))
    return LeastCircle(surface[:, 0], surface[:, 1], cu_pa, unit_weight_n_m3, supports).search()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--height", type=float, required=True, help="slope height H (m)")
    parser.add_argument("--angle", type=float, required=True, help="face angle (deg)")
    parser.add_argument("--cu", type=float, required=True, help="undrained strength (Pa)")
    parser.add_argument("--unit-weight", type=float, required=True, help="unit weight (N/m3)")
    parser.add_argument("--foundation-depth", type=float, default=0.0, help="depth below the toe to the base (m)")
    args = parser.parse_args(argv)
    circle = slope_least_circle(args.height, args.angle, args.cu, args.unit_weight, args.foundation_depth)
    n = args.cu / (circle.fos * args.unit_weight * args.height)
    print(f"least circle: F = {circle.fos:.4f} (N = cu / (F gamma H) = {n:.4f}), centre ({circle.xc_m:.3f}, "
          f"{circle.yc_m:.3f}) m, R = {circle.radius_m:.3f} m")


if __name__ == "__main__":
    main()
