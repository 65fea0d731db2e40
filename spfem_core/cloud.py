"""Particle clouds: fill a polygon with particles of nominal spacing h.

A cloud is an (n, 2) float64 array of positions in metres.  Particles lie on every polygon
edge (so the boundary is sharp and every vertex is a particle) and on a square lattice of
spacing h inside, anchored at the polygon's minimum (x, y).  Particles are ordered along a
Morton (Z-order) curve on cells of size h so that neighbours are close in memory.
"""

from __future__ import annotations

import numpy as np

MAX_JITTER = 0.3
"""Interior jitter must be below this fraction of h (keeps particles >= 0.2 h off the edges)."""

_ON_EDGE_REL_TOL = 1e-9
"""Relative tolerance (of the polygon size) for a point to count as lying on an edge."""


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


def points_in_polygon(points, polygon_m, tol_m: float | None = None) -> np.ndarray:
    """Boolean mask of ``points`` (n, 2) inside ``polygon_m`` (even-odd ray casting).

    A point crosses edge (x_i, y_i)-(x_j, y_j) to its right when (y_i > y) != (y_j > y) and
    x < x_i + (y - y_i)(x_j - x_i)/(y_j - y_i); it is inside when the count is odd.  Points
    within ``tol_m`` of an edge (default 1e-9 times the polygon's bounding-box diagonal)
    count as inside.
    """
    polygon_m = _validated_polygon(polygon_m, "polygon_m")
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points: expected shape (n, 2), got {points.shape}")
    if tol_m is None:
        tol_m = _ON_EDGE_REL_TOL * _polygon_size_m(polygon_m)
    inside = _ray_casting_inside(points, polygon_m)
    on_edge = _distance_to_edges_m(points, polygon_m) <= tol_m
    return inside | on_edge


# --------------------------------------------------------------------------------------
# validation


def _validated_polygon(polygon_m, name: str) -> np.ndarray:
    """The polygon as an (m, 2) float64 array, checked: >= 3 vertices, finite, simple."""
    try:
        polygon_m = np.array(polygon_m, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: not an array of (x, y) vertices ({error})") from None
    if polygon_m.ndim != 2 or polygon_m.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (m, 2), got {polygon_m.shape}")
    if polygon_m.shape[0] > 3 and np.array_equal(polygon_m[0], polygon_m[-1]):
        polygon_m = polygon_m[:-1]  # a closed ring: drop the repeated first vertex
    if polygon_m.shape[0] < 3:
        raise ValueError(f"{name}: needs at least 3 vertices, got {polygon_m.shape[0]}")
    if not np.all(np.isfinite(polygon_m)):
        raise ValueError(f"{name}: vertices must be finite")
    edge_length_m = np.hypot(*(np.roll(polygon_m, -1, axis=0) - polygon_m).T)
    size_m = _polygon_size_m(polygon_m)
    short = np.flatnonzero(edge_length_m <= _ON_EDGE_REL_TOL * size_m)
    if short.size:
        raise ValueError(f"{name}: zero-length edge after vertex {int(short[0])}")
    crossing = _first_self_intersection(polygon_m)
    if crossing is not None:
        raise ValueError(f"{name}: self-intersecting, edges {crossing[0]} and {crossing[1]} meet")
    if abs(_signed_area_m2(polygon_m)) <= _ON_EDGE_REL_TOL * size_m**2:
        raise ValueError(f"{name}: polygon has zero area")
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


def _polygon_size_m(polygon_m: np.ndarray) -> float:
    """Diagonal of the bounding box, the length scale of tolerances."""
    return float(np.hypot(*np.ptp(polygon_m, axis=0)))


def _signed_area_m2(polygon_m: np.ndarray) -> float:
    """Shoelace formula A = 1/2 sum (x_i y_{i+1} - x_{i+1} y_i); > 0 counter-clockwise."""
    x, y = polygon_m[:, 0], polygon_m[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _first_self_intersection(polygon_m: np.ndarray) -> tuple[int, int] | None:
    """First pair of non-adjacent edges that touch or cross (O(m^2), polygons are small)."""
    m = polygon_m.shape[0]
    start = polygon_m
    end = np.roll(polygon_m, -1, axis=0)
    tol = _ON_EDGE_REL_TOL * _polygon_size_m(polygon_m)
    for i in range(m):
        for j in range(i + 2, m):
            if i == 0 and j == m - 1:
                continue  # adjacent through the closing vertex
            if _segments_touch(start[i], end[i], start[j], end[j], tol):
                return i, j
    return None


def _segments_touch(p0, p1, q0, q1, tol: float) -> bool:
    """True when segments p0-p1 and q0-q1 cross or come within ``tol`` of each other."""

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    d1, d2 = cross(q0, q1, p0), cross(q0, q1, p1)
    d3, d4 = cross(p0, p1, q0), cross(p0, p1, q1)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return True  # proper crossing
    ends = np.array([p0, p1, q0, q1])
    dist = min(
        _distance_to_edges_m(ends[:2], np.array([q0, q1]), closed=False).min(),
        _distance_to_edges_m(ends[2:], np.array([p0, p1]), closed=False).min(),
    )
    return dist <= tol


# --------------------------------------------------------------------------------------
# geometry


def _distance_to_edges_m(points: np.ndarray, polygon_m: np.ndarray, closed: bool = True) -> np.ndarray:
    """Distance of each point to the nearest edge: |p - a - clip(t, 0, 1)(b - a)|,
    t = (p - a).(b - a)/|b - a|^2.  ``closed=False`` treats the vertices as a polyline."""
    start = polygon_m if closed else polygon_m[:-1]
    end = np.roll(polygon_m, -1, axis=0) if closed else polygon_m[1:]
    distance_m = np.full(points.shape[0], np.inf)
    for a, b in zip(start, end):
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
        nearest = a + t[:, None] * ab
        distance_m = np.minimum(distance_m, np.hypot(*(points - nearest).T))
    return distance_m


def _ray_casting_inside(points: np.ndarray, polygon_m: np.ndarray) -> np.ndarray:
    """Even-odd rule: odd number of edge crossings of the ray from the point towards +x."""
    x, y = points[:, 0], points[:, 1]
    inside = np.zeros(points.shape[0], dtype=bool)
    for (xi, yi), (xj, yj) in zip(polygon_m, np.roll(polygon_m, -1, axis=0)):
        if yi == yj:
            continue  # a horizontal edge never straddles
        straddles = (yi > y) != (yj > y)
        x_cross = xi + (y - yi) * (xj - xi) / (yj - yi)
        inside ^= straddles & (x < x_cross)
    return inside


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
    keep = _ray_casting_inside(lattice_m, polygon_m)
    lattice_m = lattice_m[keep]
    keep = _distance_to_edges_m(lattice_m, polygon_m) >= 0.5 * h * (1.0 - 1e-9)
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
