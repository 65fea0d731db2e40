"""Particle clouds: fill a polygon with particles of nominal spacing h, or of a spacing that
varies from refined zones outwards.

A cloud is an (n, 2) float64 array of positions in metres.  Particles lie on every polygon
edge (so the boundary is sharp and every vertex is a particle) and on a square lattice of
spacing h inside, anchored at the polygon's minimum (x, y).  Particles are ordered along a
Morton (Z-order) curve on cells of size h so that neighbours are close in memory.

A graded cloud (:func:`graded_particles_in_polygon`) follows a spacing field

    h(x) = min(h_0, min_z (h_z + (g - 1) d_z(x)))        (:func:`spacing_field`)

with h_z the spacing of refined zone z (a polygon), d_z(x) the distance of x to it (0 inside)
and g >= 1 the grading: the spacing grows by at most a factor g per spacing of distance, so
neighbouring particles differ in spacing by about g at most.  Its interior is made of lattices
of spacing h_k = h_0 / 2^k (the last one h_min = min_z h_z), each filling where h(x) rounds to
its level; a particle closer than ``GAP`` h_k to one of a finer level is left out.  Edge
particles follow h(x) along each edge.  Every particle carries h(x) at its position (at least
its level's spacing, up to twice it where the levels meet): the alpha shape of its triangles.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.geometry import (
    corner_vertices,
    distance_to_edges_m,
    points_near_edges,
    polygon_problem,
    ray_casting_inside,
)

MAX_JITTER = 0.3
"""Interior jitter must be below this fraction of h (keeps particles >= 0.2 h off the edges)."""


GAP = 0.5
"""A coarser particle closer than this fraction of its own spacing to a finer one is left out."""


def particles_in_polygon(polygon_m, spacing_m: float, jitter: float = 0.0, seed=0) -> np.ndarray:
    """Particles filling ``polygon_m`` (m, 2) with nominal spacing ``spacing_m`` h.

    (a) Edge particles: each edge of length L is split into ceil(L/h) equal segments; each
        polygon vertex appears once.
    (b) Interior particles: lattice points (x_min + i h, y_min + j h) strictly inside the
        polygon whose distance to every edge is >= h/2.
    (c) Optional jitter: each interior particle moves by U(-jitter h, +jitter h) per
        coordinate, drawn from ``numpy.random.default_rng(seed)``; 0 <= jitter < 0.3.

    Either vertex orientation is accepted; a closing vertex equal to the first is ignored.
    Returns an (n, 2) float64 C-contiguous array in Morton order.
    """
    polygon_m = _validated_polygon(polygon_m, "polygon_m")
    h = _validated_spacing(spacing_m)
    if not (np.isfinite(jitter) and 0.0 <= jitter < MAX_JITTER):
        raise ValueError(f"jitter: must be in [0, {MAX_JITTER}), got {jitter}")

    edge_xy_m = _edge_particles(polygon_m, h)
    interior_xy_m = _interior_lattice(polygon_m, h)
    if jitter > 0.0 and interior_xy_m.shape[0]:
        rng = np.random.default_rng(seed)
        interior_xy_m = interior_xy_m + rng.uniform(-jitter * h, jitter * h, size=interior_xy_m.shape)

    node_xy_m = np.concatenate([edge_xy_m, interior_xy_m])
    order = _morton_order(node_xy_m, h)
    return np.ascontiguousarray(node_xy_m[order], dtype=np.float64)


def spacing_field(points_m, spacing_m: float, zones, grading: float) -> np.ndarray:
    """h(x) of the module doc at ``points_m`` (n, 2); ``zones``: (polygon (m, 2), spacing) pairs."""
    points_m = np.asarray(points_m, dtype=np.float64).reshape(-1, 2)
    field = np.full(points_m.shape[0], float(spacing_m))
    for polygon, zone_spacing in zones:
        polygon = np.asarray(polygon, dtype=np.float64)
        distance = np.where(ray_casting_inside(points_m, polygon), 0.0, distance_to_edges_m(points_m, polygon))
        field = np.minimum(field, float(zone_spacing) + (grading - 1.0) * distance)
    return field


def level_spacings(spacing_m: float, finest_m: float) -> np.ndarray:
    """h_k = h_0 / 2^k down to the finest spacing (the last level is exactly ``finest_m``)."""
    levels = [float(spacing_m)]
    while levels[-1] / 2.0 > finest_m * (1.0 + 1e-9):
        levels.append(levels[-1] / 2.0)
    if levels[-1] > finest_m * (1.0 + 1e-9):
        levels.append(float(finest_m))
    return np.array(levels)


def graded_particles_in_polygon(polygon_m, spacing_m: float, zones, grading: float, jitter: float = 0.0,
                                seed=0) -> tuple[np.ndarray, np.ndarray]:
    """(positions (n, 2), spacing of each particle (n,)) of a graded cloud (module doc): ``zones``
    are (polygon, spacing) pairs with spacings in (0, spacing_m], ``grading`` >= 1.  Without zones
    it is :func:`particles_in_polygon` with every spacing h_0.  Morton order on the finest cells."""
    polygon_m = _validated_polygon(polygon_m, "polygon_m")
    h0 = _validated_spacing(spacing_m)
    zones = [(_validated_polygon(polygon, "zone polygon"), _validated_spacing(h)) for polygon, h in zones]
    if not (np.isfinite(grading) and grading >= 1.0):
        raise ValueError(f"grading: must be >= 1, got {grading}")
    if any(h > h0 * (1.0 + 1e-9) for _, h in zones):
        raise ValueError(f"zone spacings must be <= spacing_m = {h0:g}")
    if not (np.isfinite(jitter) and 0.0 <= jitter < MAX_JITTER):
        raise ValueError(f"jitter: must be in [0, {MAX_JITTER}), got {jitter}")
    if not zones:
        node_xy_m = particles_in_polygon(polygon_m, h0, jitter, seed)
        return node_xy_m, np.full(node_xy_m.shape[0], h0)
    levels = level_spacings(h0, min(h for _, h in zones))
    edge_xy_m = _graded_edge_particles(polygon_m, lambda xy: spacing_field(xy, h0, zones, grading))
    edge_h = _level_of(spacing_field(edge_xy_m, h0, zones, grading), levels)
    kept_xy, kept_h = [edge_xy_m], [edge_h]
    rng = np.random.default_rng(seed)
    for k in range(levels.size - 1, -1, -1):  # finest first
        h = levels[k]
        lattice = _interior_lattice(polygon_m, h)
        lattice = lattice[_level_of(spacing_field(lattice, h0, zones, grading), levels) == h]
        if jitter > 0.0 and lattice.shape[0]:
            lattice = lattice + rng.uniform(-jitter * h, jitter * h, size=lattice.shape)
        finer = np.concatenate(kept_xy)
        if lattice.shape[0] and finer.shape[0]:
            distance, _ = cKDTree(finer).query(lattice)
            lattice = lattice[distance >= GAP * h]
        kept_xy.append(lattice)
        kept_h.append(np.full(lattice.shape[0], h))
    node_xy_m = np.concatenate(kept_xy)
    node_h = np.maximum(np.concatenate(kept_h), spacing_field(node_xy_m, h0, zones, grading))
    order = _morton_order(node_xy_m, float(levels[-1]))
    return np.ascontiguousarray(node_xy_m[order]), np.ascontiguousarray(node_h[order])


def _level_of(field_m: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """The level spacing of each value of the field: the largest h_k <= h(x) (the finest below)."""
    index = np.searchsorted(-levels, -field_m * (1.0 + 1e-9), side="left")  # levels descending
    return levels[np.clip(index, 0, levels.size - 1)]


def _graded_edge_particles(polygon_m: np.ndarray, field) -> np.ndarray:
    """Points on every edge a-b at the local spacing: n = ceil(integral of ds / h(s)) equal steps
    of that integral (the integral sampled at 1,000 points per edge), on the corners' edges."""
    chunks = []
    polygon_m = corner_vertices(polygon_m)
    for a, b in zip(polygon_m, np.roll(polygon_m, -1, axis=0)):
        length_m = float(np.hypot(*(b - a)))
        s = np.linspace(0.0, 1.0, 1001)
        inverse_h = 1.0 / field(a + s[:, None] * (b - a))
        cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (inverse_h[1:] + inverse_h[:-1]) * np.diff(s))]) * length_m
        n_seg = max(1, int(np.ceil(cumulative[-1] - 1e-9)))
        t = np.interp(np.arange(n_seg) * cumulative[-1] / n_seg, cumulative, s)
        chunks.append(a + t[:, None] * (b - a))
    return np.concatenate(chunks)


# --------------------------------------------------------------------------------------
# validation


def _validated_polygon(polygon_m, name: str) -> np.ndarray:
    """The polygon as an (m, 2) float64 array, checked (``geometry.polygon_problem``); a closing
    vertex equal to the first is dropped."""
    try:
        polygon_m = np.array(polygon_m, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: not an array of (x, y) vertices ({error})") from None
    if polygon_m.ndim != 2 or polygon_m.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (m, 2), got {polygon_m.shape}")
    if polygon_m.shape[0] > 3 and np.array_equal(polygon_m[0], polygon_m[-1]):
        polygon_m = polygon_m[:-1]  # a closed ring: drop the repeated first vertex
    problem = polygon_problem(polygon_m)
    if problem is not None:
        raise ValueError(f"{name}: {problem}")
    return np.ascontiguousarray(polygon_m)


def _validated_spacing(spacing_m) -> float:
    """h as a float, checked finite and > 0."""
    try:
        h = float(spacing_m)
    except (TypeError, ValueError):
        raise ValueError(f"spacing_m: must be a number > 0, got {spacing_m!r}") from None
    if not (np.isfinite(h) and h > 0.0):
        raise ValueError(f"spacing_m: must be finite and > 0, got {spacing_m}")
    return h


# --------------------------------------------------------------------------------------
# the lattice


def _edge_particles(polygon_m: np.ndarray, h: float) -> np.ndarray:
    """Points a + (k/n)(b - a), k = 0..n-1, n = ceil(L/h), on every edge a-b of the corners
    (``geometry.corner_vertices``: a vertex in the middle of a straight side adds no particle)."""
    chunks = []
    polygon_m = corner_vertices(polygon_m)
    for a, b in zip(polygon_m, np.roll(polygon_m, -1, axis=0)):
        length_m = float(np.hypot(*(b - a)))
        n_seg = max(1, int(np.ceil(length_m / h - 1e-9)))  # 2.0 / 0.02 = 100.00000000000001
        t = np.arange(n_seg) / n_seg
        chunks.append(a + t[:, None] * (b - a))
    return np.concatenate(chunks)


def _interior_lattice(polygon_m: np.ndarray, h: float) -> np.ndarray:
    """Lattice points (x_min + i h, y_min + j h) strictly inside, >= h/2 from every edge."""
    low_m = polygon_m.min(axis=0)
    n_x, n_y = (np.floor(np.ptp(polygon_m, axis=0) / h + 1e-9).astype(np.int64) + 1).tolist()
    i, j = np.meshgrid(np.arange(n_x), np.arange(n_y), indexing="xy")
    lattice_m = low_m + h * np.column_stack([i.ravel(), j.ravel()]).astype(np.float64)
    keep = ray_casting_inside(lattice_m, polygon_m)
    lattice_m = lattice_m[keep]
    return lattice_m[~points_near_edges(lattice_m, polygon_m, 0.5 * h * (1.0 - 1e-9))]


def _morton_order(node_xy_m: np.ndarray, h: float) -> np.ndarray:
    """Permutation sorting particles by the Z-order key of their h-sized cell.

    key = interleave(bits of i_x, bits of i_y) with i = floor((x - x_min)/h); ties (several
    particles in one cell) are broken by y then x so the order is deterministic.
    """
    cell = np.floor((node_xy_m - node_xy_m.min(axis=0)) / h).astype(np.uint64)
    key = _spread_bits(cell[:, 0]) | (_spread_bits(cell[:, 1]) << np.uint64(1))
    return np.lexsort((node_xy_m[:, 0], node_xy_m[:, 1], key))


def _spread_bits(value: np.ndarray) -> np.ndarray:
    """Insert a zero bit between the low 32 bits of each value (Morton 'part 1 by 1')."""
    v = value.astype(np.uint64) & np.uint64(0x00000000FFFFFFFF)
    for shift, mask in (
        (16, 0x0000FFFF0000FFFF),
        (8, 0x00FF00FF00FF00FF),
        (4, 0x0F0F0F0F0F0F0F0F),
        (2, 0x3333333333333333),
        (1, 0x5555555555555555),
    ):
        v = (v | (v << np.uint64(shift))) & np.uint64(mask)
    return v
