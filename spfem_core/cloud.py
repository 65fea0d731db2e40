"""Particle clouds: fill a polygon with particles of nominal spacing h.

A cloud is an (n, 2) float64 array of positions in metres.  Particles lie on every polygon
edge (so the boundary is sharp and every vertex is a particle) and on a square lattice of
spacing h inside, anchored at the polygon's minimum (x, y).  Particles are ordered along a
Morton (Z-order) curve on cells of size h so that neighbours are close in memory.
"""

from __future__ import annotations

import numpy as np

from spfem_core.geometry import distance_to_edges_m, polygon_problem, ray_casting_inside

MAX_JITTER = 0.3
"""Interior jitter must be below this fraction of h (keeps particles >= 0.2 h off the edges)."""


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
    """Points a + (k/n)(b - a), k = 0..n-1, n = ceil(L/h), on every edge a-b."""
    chunks = []
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
    keep = distance_to_edges_m(lattice_m, polygon_m) >= 0.5 * h * (1.0 - 1e-9)
    return lattice_m[keep]


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
