"""Adaptive refinement: the zones of finer particles along the shear band of a level's mechanism.

The band is read from the first failed run of the level before (its final particle state, at the
particles' initial positions, where the next level's cloud is made) by an indicator per particle:

- ``plastic_work``: sqrt(J2) eps_p, the plastic work density of a perfectly plastic soil up to a
  constant factor (the shear stress times the equivalent plastic strain): where the mechanism
  dissipates, as limit-analysis codes refine (OptumG2's shear power);
- ``plastic_strain``: eps_p alone;
- ``mechanism``: eps_p of the failed run less eps_p of the highest stable run below it, the plastic
  strain the mechanism itself added (zones that yield without failing left out).

A particle is in the band when its indicator reaches ``BAND_FRACTION`` of the largest.  The zone is
every point within ``reach`` of a band particle: the distance to the nearest band particle is
sampled on a grid of cells a quarter of the reach, and the zone's outlines are that field's
contour at the reach (contourpy, matplotlib's contouring), simplified to a tenth of the reach
(Ramer-Douglas-Peucker).  A band of any shape (curved, steep, several branches) gives its own
outlines; each becomes a refined zone (``spfem_core.cloud``, graded around it).
"""

from __future__ import annotations

from typing import cast

import numpy as np
import xarray as xr
from scipy.spatial import cKDTree

from spfem_core.geometry import polygon_problem

BAND_FRACTION = 0.25
"""A particle is in the band when its indicator reaches this fraction of the largest."""
MIN_BAND_PARTICLES = 3
"""A band of fewer particles gives no zone."""
CELLS_PER_REACH = 4
"""The grid on which the zone's outline is drawn has this many cells per reach."""
SIMPLIFY_PER_REACH = 0.1
"""Outline vertices closer than this fraction of the reach to the simplified line are dropped."""


def _particles(path, fields=("particle_x0", "particle_y0", "particle_plastic_strain", "particle_sxx",
                             "particle_syy", "particle_szz", "particle_sxy")) -> dict:
    with xr.open_dataset(path) as ds:
        return {name: ds[name].values for name in fields if name in ds}


def band_indicator(indicator: str, failed_path, stable_path=None) -> tuple[np.ndarray, np.ndarray]:
    """(initial positions (n, 2), indicator (n,)) of the run file ``failed_path`` (module doc);
    ``stable_path``: the highest stable run below it (``mechanism`` only; none: its plastic strain alone)."""
    run = _particles(failed_path)
    xy0 = np.column_stack([run["particle_x0"], run["particle_y0"]])
    strain = run["particle_plastic_strain"]
    if indicator == "plastic_strain":
        return xy0, strain
    if indicator == "plastic_work":
        sxx, syy, szz, sxy = (run[f"particle_s{c}"] for c in ("xx", "yy", "zz", "xy"))
        mean = (sxx + syy + szz) / 3.0
        j2 = 0.5 * ((sxx - mean) ** 2 + (syy - mean) ** 2 + (szz - mean) ** 2) + sxy**2
        return xy0, np.sqrt(j2) * strain
    if indicator == "mechanism":
        before = _particles(stable_path, ("particle_plastic_strain",))["particle_plastic_strain"] \
            if stable_path is not None else np.zeros_like(strain)
        return xy0, np.maximum(strain - before, 0.0) if before.shape == strain.shape else strain
    raise ValueError(f"band_indicator: unknown indicator {indicator!r}")


def band_particles(xy0_m: np.ndarray, indicator: np.ndarray) -> np.ndarray:
    """The positions of the band's particles: indicator >= BAND_FRACTION of its largest (none: (0, 2))."""
    top = float(np.max(indicator)) if indicator.size else 0.0
    if not top > 0.0:
        return np.zeros((0, 2))
    return xy0_m[indicator >= BAND_FRACTION * top]


def zone_outlines(band_xy_m: np.ndarray, reach_m: float) -> list[np.ndarray]:
    """The outlines of every point within ``reach_m`` of a band particle (module doc), each a simple
    polygon (m, 2); none for a band of fewer than MIN_BAND_PARTICLES particles."""
    import contourpy  # matplotlib's contouring: only when a zone is drawn

    if band_xy_m.shape[0] < MIN_BAND_PARTICLES:
        return []
    cell = reach_m / CELLS_PER_REACH
    low = band_xy_m.min(axis=0) - 2.0 * reach_m
    high = band_xy_m.max(axis=0) + 2.0 * reach_m
    x = np.arange(low[0], high[0] + cell, cell)
    y = np.arange(low[1], high[1] + cell, cell)
    grid_x, grid_y = np.meshgrid(x, y)
    distance, _ = cKDTree(band_xy_m).query(np.column_stack([grid_x.ravel(), grid_y.ravel()]))
    inside = reach_m - distance.reshape(grid_x.shape)  # > 0 within reach
    outlines = []
    # the default line type (LineType.Separate): one (n, 2) array a line
    lines = cast(list[np.ndarray], contourpy.contour_generator(x, y, inside).lines(0.0))
    for line in lines:
        if line.shape[0] < 4:
            continue
        ring = line[:-1] if np.allclose(line[0], line[-1]) else line
        simple = _simplified(ring, SIMPLIFY_PER_REACH * reach_m)
        if simple.shape[0] < 3 or polygon_problem(simple) is not None:
            simple = ring
        if polygon_problem(simple) is None and _area(simple) > 0.5 * np.pi * (0.5 * reach_m) ** 2:
            outlines.append(simple)
    return outlines


def _area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _simplified(ring: np.ndarray, tolerance_m: float) -> np.ndarray:
    """Ramer-Douglas-Peucker on a closed ring, split at its two most distant vertices."""
    far = int(np.argmax(np.hypot(*(ring - ring[0]).T)))
    first = _rdp(ring[: far + 1], tolerance_m)
    second = _rdp(np.concatenate([ring[far:], ring[:1]]), tolerance_m)
    return np.concatenate([first[:-1], second[:-1]])


def _rdp(points: np.ndarray, tolerance_m: float) -> np.ndarray:
    keep = np.zeros(points.shape[0], dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, points.shape[0] - 1)]
    while stack:
        start, end = stack.pop()
        if end - start < 2:
            continue
        a, b = points[start], points[end]
        direction = b - a
        length = float(np.hypot(*direction))
        middle = points[start + 1:end]
        if length == 0.0:
            distance = np.hypot(*(middle - a).T)
        else:
            distance = np.abs(direction[0] * (middle[:, 1] - a[1]) - direction[1] * (middle[:, 0] - a[0])) / length
        k = int(np.argmax(distance))
        if distance[k] > tolerance_m:
            keep[start + 1 + k] = True
            stack += [(start, start + 1 + k), (start + 1 + k, end)]
    return points[keep]
