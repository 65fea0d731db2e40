"""The least log-spiral rotational mechanism of a homogeneous c-phi slope: a rigorous upper bound on
its strength-reduction FOS (associated Mohr-Coulomb), with pore pressure from ru.

    python -m verification.log_spiral --ground 0,15 20,15 40,5 60,5 --cohesion 10e3 --friction 20 \\
        --unit-weight 20e3 [--ru 0.2]

A rigid block bounded by the ground and a log spiral r(t) = r0 exp((t - t0) k), k = tan(phi_F),
turns about the spiral's pole O = (xc, yc) at the rate w > 0 (counter-clockwise, the crest on the
left: the block moves towards +x at its base).  Its velocity w r makes the angle phi_F with the
spiral, away from the soil at rest (normality of Mohr-Coulomb), so that the work balance of the
mechanism (Chen 1975, "Limit Analysis and Soil Plasticity", ch. 9; pore water as Michalowski 1995,
"Slope stability analysis: a kinematical approach", Geotechnique 45(2):283-293) is

    dissipation   D = (c / F) w int r^2 dt = (c / F) w r0^2 (exp(2 k (t1 - t0)) - 1) / (2 k)
    gravity       W = gamma w int_block (xc - x) dA
    pore water    P = w k int u r^2 dt          (u = ru gamma z, z the depth below the ground above)

and the strength reduced by F, c / F and tan(phi) / F, cannot hold the block when D <= W + P: the
collapse SRF of the slope is at most the F that balances them, for every admissible spiral (the
kinematic theorem; with pore pressure, of the effective-stress problem with u prescribed).  A
spiral is admissible when it lies above the base (y >= 0), where the soil is held.  For each pole
and entry point on the ground, the balance is solved for F (the spiral's shape follows phi_F); the
least F is searched on a grid of poles and entry points, then polished by Nelder-Mead.  The block's
area and moment are integrated in x between the spiral and the ground (midpoint rule,
``INTEGRATION_POINTS``).  Checked against limit equilibrium in ``tests/test_log_spiral.py``: for
phi = 0 the spiral is the least circle (``verification.least_circle``).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, minimize

INTEGRATION_POINTS = 4000
"""Points along the spiral (and midpoints in x of the block) of the final mechanism."""
SEARCH_POINTS = 600
"""The same, during the grid search."""


@dataclass(frozen=True)
class Spiral:
    entry_x_m: float
    exit_x_m: float
    turn_rad: float  # the angle the spiral turns about its pole from entry to exit
    xc_m: float  # its pole at the least F
    yc_m: float
    fos: float


class Ground:
    """The ground y = g(x) over [x_min, x_max] (a polyline), the soil between it and the base y = 0."""

    def __init__(self, points_m):
        points = np.asarray(points_m, dtype=float)
        self.x, self.y = points[:, 0], points[:, 1]

    def __call__(self, x):
        return np.interp(x, self.x, self.y)

    @property
    def x_min(self) -> float:
        return float(self.x[0])

    @property
    def x_max(self) -> float:
        return float(self.x[-1])


def spiral_through(entry_m, exit_m, turn_rad: float, k: float):
    """(pole (2,), r0, t0) of the log spiral r = r0 exp(k (t - t0)) that leaves ``entry_m`` at the
    angle t0 about its pole and reaches ``exit_m`` after turning ``turn_rad`` counter-clockwise:
    X - E = r0 R(t0) (rho u(turn) - u(0)), rho = exp(k turn), u(t) = (cos t, sin t)."""
    rho = math.exp(k * turn_rad)
    w = np.array([rho * math.cos(turn_rad) - 1.0, rho * math.sin(turn_rad)])
    chord = np.asarray(exit_m, dtype=float) - np.asarray(entry_m, dtype=float)
    r0 = float(np.hypot(*chord) / np.hypot(*w))
    t0 = math.atan2(chord[1], chord[0]) - math.atan2(w[1], w[0])
    pole = np.asarray(entry_m, dtype=float) - r0 * np.array([math.cos(t0), math.sin(t0)])
    return pole, r0, t0


def _balance_terms(entry_x, exit_x, turn, ground: Ground, k: float, ru: float, unit_weight: float, n: int):
    """(integral of r^2 dt, gravity moment W / w, pore water integral of u r^2 dt, pole) of the block
    between the ground and the spiral from the entry to the exit point, or None where inadmissible
    (the spiral crosses the ground between them, dips below the base, or turns back in x)."""
    entry = (entry_x, float(ground(entry_x)))
    exit_ = (exit_x, float(ground(exit_x)))
    pole, r0, t0 = spiral_through(entry, exit_, turn, k)
    ts = t0 + np.linspace(0.0, turn, n)
    rs = r0 * np.exp(k * (ts - t0))
    xs, ys = pole[0] + rs * np.cos(ts), pole[1] + rs * np.sin(ts)
    if np.any(np.diff(xs) <= 0.0) or ys.min() < -1e-9:
        return None
    if np.any(ys[1:-1] > ground(xs[1:-1]) + 1e-9):
        return None
    dissipation = r0**2 * ((math.exp(2.0 * k * turn) - 1.0) / (2.0 * k) if k > 0.0 else turn)
    edges = np.linspace(xs[0], xs[-1], n + 1)
    mid = 0.5 * (edges[1:] + edges[:-1])
    height = np.clip(ground(mid) - np.interp(mid, xs, ys), 0.0, None)
    gravity = unit_weight * float(np.sum(height * np.diff(edges) * (pole[0] - mid)))
    pore = 0.0
    if ru > 0.0:
        tm = 0.5 * (ts[1:] + ts[:-1])
        rm = r0 * np.exp(k * (tm - t0))
        depth = np.clip(ground(pole[0] + rm * np.cos(tm)) - (pole[1] + rm * np.sin(tm)), 0.0, None)
        pore = k * float(np.sum(ru * unit_weight * depth * rm**2 * np.diff(ts)))
    return dissipation, gravity, pore, pole


def spiral_fos(entry_x, exit_x, turn, ground: Ground, cohesion_pa: float, friction_deg: float, unit_weight: float,
               ru: float = 0.0, n: int = SEARCH_POINTS) -> float:
    """The F that balances the mechanism (entry, exit, turn) (inf: none)."""
    if not (ground.x_min <= entry_x < exit_x <= ground.x_max and 0.0 < turn < 2.0 * math.pi):
        return math.inf
    tan_phi = math.tan(math.radians(friction_deg))

    def excess(f: float) -> float:
        terms = _balance_terms(entry_x, exit_x, turn, ground, tan_phi / f, ru, unit_weight, n)
        if terms is None:
            return math.nan
        dissipation, gravity, pore, _ = terms
        return cohesion_pa / f * dissipation - gravity - pore

    grid = np.geomspace(0.1, 20.0, 30)
    values = np.array([excess(f) for f in grid])
    for i in range(grid.size - 1):  # D - W falls as F grows: the first change of sign
        if np.isfinite(values[i]) and np.isfinite(values[i + 1]) and values[i] > 0.0 >= values[i + 1]:
            try:
                return float(brentq(excess, grid[i], grid[i + 1], xtol=1e-10))
            except ValueError:
                return math.inf
    return math.inf


def least_spiral(ground_points_m, cohesion_pa: float, friction_deg: float, unit_weight: float, ru: float = 0.0,
                 grid: int = 16) -> Spiral:
    """The least F over entry and exit points and turns (module doc)."""
    ground = Ground(ground_points_m)
    span = ground.x_max - ground.x_min

    def f(p, n=SEARCH_POINTS):
        return spiral_fos(p[0], p[1], p[2], ground, cohesion_pa, friction_deg, unit_weight, ru, n)

    best, start = math.inf, None
    xs = np.linspace(ground.x_min, ground.x_max, grid)
    for i, entry in enumerate(xs):
        for exit_ in xs[i + 1:]:
            for turn in np.linspace(0.2, 2.6, grid):
                value = f((entry, exit_, turn))
                if value < best:
                    best, start = value, np.array([entry, exit_, turn])
    if start is None:
        raise ValueError("least_spiral: no admissible mechanism found")
    step = np.array([0.03 * span, 0.03 * span, 0.1])
    result = start
    for _ in range(3):  # restarts: the admissible set has edges where Nelder-Mead stalls
        polished = minimize(lambda p: f(p, INTEGRATION_POINTS), result, method="Nelder-Mead",
                            options={"xatol": 1e-5, "fatol": 1e-8, "maxiter": 3000, "initial_simplex": np.array(
                                [result, result + step * [1, 0, 0], result + step * [0, 1, 0], result + step * [0, 0, 1]])})
        result, step = polished.x, step / 3.0
    fos = f(result, INTEGRATION_POINTS)
    terms = _balance_terms(result[0], result[1], result[2], ground, math.tan(math.radians(friction_deg)) / fos, ru,
                           unit_weight, INTEGRATION_POINTS)
    pole = terms[3] if terms is not None else (math.nan, math.nan)
    return Spiral(float(result[0]), float(result[1]), float(result[2]), float(pole[0]), float(pole[1]), float(fos))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ground", nargs="+", required=True, help="x,y points of the ground, left to right (m)")
    parser.add_argument("--cohesion", type=float, required=True, help="c (Pa)")
    parser.add_argument("--friction", type=float, required=True, help="phi (degree)")
    parser.add_argument("--unit-weight", type=float, required=True, help="gamma (N/m3)")
    parser.add_argument("--ru", type=float, default=0.0)
    args = parser.parse_args(argv)
    points = [tuple(float(v) for v in point.split(",")) for point in args.ground]
    spiral = least_spiral(points, args.cohesion, args.friction, args.unit_weight, args.ru)
    print(f"least log spiral: F = {spiral.fos:.4f}, entry x {spiral.entry_x_m:.2f} m, exit x {spiral.exit_x_m:.2f} m, "
          f"turn {math.degrees(spiral.turn_rad):.1f} deg, pole ({spiral.xc_m:.2f}, {spiral.yc_m:.2f}) m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
