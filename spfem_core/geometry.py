"""Plane geometry of polygons and of the ground surface they bound: NumPy only, no numba.

A polygon is a sequence of (x, y) vertices in metres, either orientation, not closed (the
last vertex is joined to the first).  The study reader, the particle cloud, the memory guard,
the water, the loads, the runout metrics and the figures all use these functions, so they are
kept free of the compiled core: importing this module does not import numba.

- area and perimeter: the shoelace formula A = 1/2 sum (x_i y_{i+1} - x_{i+1} y_i) (> 0
  counter-clockwise) and P = sum |v_{i+1} - v_i|;
- :func:`polygon_problem`: why some vertices are no simple polygon (too few, a zero-length edge,
  two edges that cross or touch, zero area), with tolerances relative to the polygon's size;
- :func:`points_in_polygon`: even-odd ray casting, points on an edge count as inside;
- the **upper boundary** y_top(x), the highest edge above x (:func:`surface_height_m`), its
  extreme heights (:func:`upper_boundary_heights`) and their difference, the **relief**: the
  height of a slope from its toe to its crest (:func:`relief_m`).
"""

from __future__ import annotations

import math

import numpy as np

ON_EDGE_REL_TOL = 1e-9
"""Relative tolerance (of the polygon's size, the diagonal of its bounding box) for a point to
lie on an edge, an edge to have zero length, or two edges to touch."""


def vertices_m(polygon) -> np.ndarray:
    """The vertices as an (m, 2) float64 array (no checks)."""
    return np.asarray(polygon, dtype=np.float64).reshape(-1, 2)


def size_m(polygon) -> float:
    """Diagonal of the bounding box: the length scale of the tolerances."""
    return float(np.hypot(*np.ptp(vertices_m(polygon), axis=0)))


def signed_area_m2(polygon) -> float:
    """A = 1/2 sum (x_i y_{i+1} - x_{i+1} y_i): > 0 for counter-clockwise vertices."""
    xy = vertices_m(polygon)
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def perimeter_m(polygon) -> float:
    """P = sum |v_{i+1} - v_i| around the closed polygon."""
    xy = vertices_m(polygon)
    return float(np.sum(np.hypot(*(np.roll(xy, -1, axis=0) - xy).T)))


def distance_to_edges_m(points, polygon, closed: bool = True) -> np.ndarray:
    """Distance of each point (n, 2) to the nearest edge: |p - a - clip(t, 0, 1)(b - a)| with
    t = (p - a).(b - a) / |b - a|^2.  ``closed=False`` treats the vertices as a polyline."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    xy = vertices_m(polygon)
    start = xy if closed else xy[:-1]
    end = np.roll(xy, -1, axis=0) if closed else xy[1:]
    distance = np.full(points.shape[0], np.inf)
    for a, b in zip(start, end):
        ab = b - a
        t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
        nearest = a + t[:, None] * ab
        distance = np.minimum(distance, np.hypot(*(points - nearest).T))
    return distance


PAIRS_PER_BATCH = 1 << 20
"""Pairs (of two edges, or of an edge and an abscissa) handled at once by the sweeps below: it
bounds their memory whatever the polygon."""


def _batches(counts: np.ndarray):
    """(k0, k1) ranges of ``counts`` that sum to about ``PAIRS_PER_BATCH`` (at least one entry each)."""
    k0, total = 0, np.cumsum(counts)
    while k0 < counts.size:
        before = total[k0 - 1] if k0 else 0
        k1 = max(k0 + 1, int(np.searchsorted(total, before + PAIRS_PER_BATCH, side="right")))
        yield k0, k1
        k0 = k1


def _ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """starts[0], ..., starts[0] + counts[0] - 1, starts[1], ...: the ranges concatenated."""
    return np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())


def _edges_over(x_sorted: np.ndarray, x_low: np.ndarray, x_high: np.ndarray):
    """Batches of (edge, query) index pairs with x_low[edge] <= x_sorted[query] <= x_high[edge]: the
    queries each edge spans, found by bisection (a sweep along x)."""
    first = np.searchsorted(x_sorted, x_low, side="left")
    counts = np.maximum(np.searchsorted(x_sorted, x_high, side="right") - first, 0)
    for e0, e1 in _batches(counts):
        yield np.repeat(np.arange(e0, e1), counts[e0:e1]), _ranges(first[e0:e1], counts[e0:e1])


def _point_segment_distance_m(p, a, b) -> np.ndarray:
    """|p - a - clip(t, 0, 1)(b - a)|, t = (p - a).(b - a) / |b - a|^2, row by row of (k, 2) arrays."""
    ab, ap = b - a, p - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(length2 > 0.0, length2, 1.0), 0.0, 1.0)
    return np.hypot(*(ap - t[:, None] * ab).T)


def points_near_edges(points, polygon, distance_m: float) -> np.ndarray:
    """Whether each point (n, 2) lies closer than ``distance_m`` to an edge of ``polygon``: as
    ``distance_to_edges_m(points, polygon) < distance_m``, each point tested only against the edges
    whose box, grown by ``distance_m``, holds it (a sweep along x): a long surveyed ground line
    costs what its neighbourhood does, not every edge for every point."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    start, end = _edges(polygon)
    low, high = np.minimum(start, end) - distance_m, np.maximum(start, end) + distance_m
    order = np.argsort(points[:, 0], kind="stable")
    by_x = points[order]
    near = np.zeros(points.shape[0], dtype=bool)
    for e, q in _edges_over(by_x[:, 0], low[:, 0], high[:, 0]):
        beside = (by_x[q, 1] >= low[e, 1]) & (by_x[q, 1] <= high[e, 1])
        e, q = e[beside], q[beside]
        close = _point_segment_distance_m(by_x[q], start[e], end[e]) < distance_m
        near[order[q[close]]] = True
    return near


def _segments_touch(p0, p1, q0, q1, tol_m: float) -> np.ndarray:
    """Row by row of (k, 2) arrays: True where the segments p0-p1 and q0-q1 cross (each one's ends
    strictly on either side of the other's line) or come within ``tol_m`` of each other (the
    nearest of an end of one to the other segment)."""

    def cross(o, a, b):
        return (a[:, 0] - o[:, 0]) * (b[:, 1] - o[:, 1]) - (a[:, 1] - o[:, 1]) * (b[:, 0] - o[:, 0])

    crossing = (cross(q0, q1, p0) * cross(q0, q1, p1) < 0.0) & (cross(p0, p1, q0) * cross(p0, p1, q1) < 0.0)
    gap = np.minimum.reduce([_point_segment_distance_m(p0, q0, q1), _point_segment_distance_m(p1, q0, q1),
                             _point_segment_distance_m(q0, p0, p1), _point_segment_distance_m(q1, p0, p1)])
    return crossing | (gap <= tol_m)


def first_self_intersection(polygon) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of non-adjacent edges that cross or touch (edge i runs from
    vertex i to vertex i + 1; the first: the smallest i, then j); None for a simple polygon.

    A sweep along x: the edges sorted by their lowest x, each is tested (vectorised) against the
    edges that start before it ends, whose boxes (grown by the tolerance) overlap its own in y too.
    On a ground line, whose edges follow each other in x, that is a few pairs per edge: a 10,000
    vertex polygon takes a fraction of a second."""
    xy = vertices_m(polygon)
    m = xy.shape[0]
    start, end = xy, np.roll(xy, -1, axis=0)
    tol = ON_EDGE_REL_TOL * size_m(xy)
    low, high = np.minimum(start, end) - tol, np.maximum(start, end) + tol
    order = np.argsort(low[:, 0], kind="stable")
    # the edges after sorted position a that start (in x) before edge order[a] ends: a+1 ... last[a]-1
    last = np.searchsorted(low[order, 0], high[order, 0], side="right")
    counts = np.maximum(last - np.arange(m) - 1, 0)
    first = None
    for a0, a1 in _batches(counts):
        a = np.repeat(np.arange(a0, a1), counts[a0:a1])
        b = _ranges(np.arange(a0, a1) + 1, counts[a0:a1])
        i, j = np.minimum(order[a], order[b]), np.maximum(order[a], order[b])
        keep = (j - i > 1) & ~((i == 0) & (j == m - 1))  # not adjacent, nor through the closing vertex
        keep &= (low[i, 1] <= high[j, 1]) & (low[j, 1] <= high[i, 1])
        i, j = i[keep], j[keep]
        hit = _segments_touch(start[i], end[i], start[j], end[j], tol)
        if hit.any():
            k = np.lexsort((j[hit], i[hit]))[0]
            pair = (int(i[hit][k]), int(j[hit][k]))
            first = pair if first is None or pair < first else first
    return first


def corner_vertices(polygon) -> np.ndarray:
    """The vertices without those that lie on the straight line between their neighbours, within
    ``ON_EDGE_REL_TOL`` of the size: the same polygon, each straight side one edge."""
    xy = vertices_m(polygon)
    tol = ON_EDGE_REL_TOL * size_m(xy)
    keep = list(range(xy.shape[0]))
    changed = True
    while changed and len(keep) > 3:
        changed = False
        for k in range(len(keep)):
            a, b, c = xy[keep[k - 1]], xy[keep[k]], xy[keep[(k + 1) % len(keep)]]
            ac = c - a
            between = 0.0 < (b - a) @ ac < ac @ ac
            if between and abs(ac[0] * (b - a)[1] - ac[1] * (b - a)[0]) <= tol * np.hypot(*ac):
                del keep[k]
                changed = True
                break
    return xy[keep]


def polygon_problem(polygon) -> str | None:
    """Why the vertices are no simple polygon of non-zero area (one phrase), or None.

    In this order: fewer than 3 vertices, vertices that are not finite, an edge shorter than
    ``ON_EDGE_REL_TOL`` of the size (two vertices coincide), two edges that cross or touch, an
    area below ``ON_EDGE_REL_TOL`` of the size squared.
    """
    xy = vertices_m(polygon)
    m = xy.shape[0]
    if m < 3:
        return f"needs at least 3 vertices, got {m}"
    if not np.all(np.isfinite(xy)):
        return "vertices must be finite"
    size = size_m(xy)
    edge_length = np.hypot(*(np.roll(xy, -1, axis=0) - xy).T)
    short = np.flatnonzero(edge_length <= ON_EDGE_REL_TOL * size)
    if short.size:
        i = int(short[0])
        return f"vertices {i} and {(i + 1) % m} coincide"
    crossing = first_self_intersection(xy)
    if crossing is not None:
        return f"edges {crossing[0]} and {crossing[1]} cross; the polygon must be simple"
    if abs(signed_area_m2(xy)) <= ON_EDGE_REL_TOL * size**2:
        return "has zero area"
    return None


def points_in_polygon(points, polygon, tol_m: float | None = None) -> np.ndarray:
    """Boolean mask of ``points`` (n, 2) inside ``polygon`` (even-odd ray casting).

    A point crosses edge (x_i, y_i)-(x_j, y_j) to its right when (y_i > y) != (y_j > y) and
    x < x_i + (y - y_i)(x_j - x_i)/(y_j - y_i); it is inside when the count is odd.  Points
    within ``tol_m`` of an edge (default ``ON_EDGE_REL_TOL`` times the polygon's size) count
    as inside.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points: expected shape (n, 2), got {points.shape}")
    xy = vertices_m(polygon)
    tol_m = ON_EDGE_REL_TOL * size_m(xy) if tol_m is None else tol_m
    return ray_casting_inside(points, xy) | (distance_to_edges_m(points, xy) <= tol_m)


def ray_casting_inside(points, polygon) -> np.ndarray:
    """Even-odd rule alone: an odd number of edge crossings of the ray from the point towards +x
    (a point on an edge may come out either way; :func:`points_in_polygon` counts it inside)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    xy = vertices_m(polygon)
    x, y = points[:, 0], points[:, 1]
    inside = np.zeros(points.shape[0], dtype=bool)
    for (xi, yi), (xj, yj) in zip(xy, np.roll(xy, -1, axis=0)):
        if yi == yj:
            continue  # a horizontal edge never straddles
        straddles = (yi > y) != (yj > y)
        x_cross = xi + (y - yi) * (xj - xi) / (yj - yi)
        inside ^= straddles & (x < x_cross)
    return inside


def _edges(polygon) -> tuple[np.ndarray, np.ndarray]:
    """(start, end) of each edge as (m, 2) arrays, in the polygon's order."""
    xy = vertices_m(polygon)
    return xy, np.roll(xy, -1, axis=0)


def surface_height_m(polygon, x) -> np.ndarray:
    """y_top(x): the height of the polygon's highest edge above each abscissa ``x`` (NaN where none).
    Each abscissa meets only the edges that span it (:func:`_edges_over`)."""
    start, end = _edges(polygon)
    x = np.asarray(x, dtype=np.float64)
    lo, hi = np.minimum(start[:, 0], end[:, 0]), np.maximum(start[:, 0], end[:, 0])
    sloped = np.flatnonzero(hi > lo)
    order = np.argsort(x.ravel(), kind="stable")
    x_sorted = x.ravel()[order]
    top = np.full(x_sorted.size, -np.inf)
    for e, q in _edges_over(x_sorted, lo[sloped], hi[sloped]):
        a, b = start[sloped[e]], end[sloped[e]]
        t = (x_sorted[q] - a[:, 0]) / (b[:, 0] - a[:, 0])
        np.maximum.at(top, q, a[:, 1] + t * (b[:, 1] - a[:, 1]))
    y = np.empty(x_sorted.size)
    y[order] = np.where(np.isfinite(top), top, np.nan)
    return y.reshape(x.shape)


def upper_boundary(polygon) -> np.ndarray:
    """The upper boundary y_top(x), the largest y of the boundary at x, as a polyline (k, 2): at every
    vertex abscissa, from left to right, its height approached from the left, then from the right
    (a vertical step where a vertical edge makes them differ; y_top is linear in between).
    Vertical edges are seen through their neighbours; each abscissa meets only the edges that
    span it (:func:`_edges_over`)."""
    start, end = _edges(polygon)
    swap = start[:, 0] > end[:, 0]
    left_end, right_end = np.where(swap[:, None], end, start), np.where(swap[:, None], start, end)
    sloped = np.flatnonzero(left_end[:, 0] < right_end[:, 0])
    (x1, y1), (x2, y2) = left_end[sloped].T, right_end[sloped].T
    abscissae = np.unique(start[:, 0])
    from_left, from_right = np.full(abscissae.size, -np.inf), np.full(abscissae.size, -np.inf)
    for e, q in _edges_over(abscissae, x1, x2):
        x0 = abscissae[q]
        at_low, at_high = x0 == x1[e], x0 == x2[e]
        inside = y1[e] + (x0 - x1[e]) * (y2[e] - y1[e]) / (x2[e] - x1[e])
        y = np.where(at_low, y1[e], np.where(at_high, y2[e], inside))
        np.maximum.at(from_left, q[~at_low], y[~at_low])
        np.maximum.at(from_right, q[~at_high], y[~at_high])
    points = np.column_stack([np.repeat(abscissae, 2), np.column_stack([from_left, from_right]).ravel()])
    return points[np.isfinite(points[:, 1])]


def upper_boundary_heights(polygon) -> list[float]:
    """Heights of the upper boundary at every vertex abscissa, approached from the left and from the
    right (:func:`upper_boundary`), where y_top takes its extreme values."""
    return upper_boundary(polygon)[:, 1].tolist()


def narrow_peaks(polygon, width_m: float) -> np.ndarray:
    """(x, y, w) rows, highest first, of the points of the upper boundary whose top ``width_m`` is
    narrower than ``width_m``: the part of y_top(x) that stays at or above y - width_m around x is
    w < width_m wide (bounded by where y_top falls below that level, or by the ends of the
    boundary).  A spike of the ground narrower than the particle spacing is one: no particle
    fills it.  Only points as high as their neighbours are tested, each against the boundary
    within ``width_m`` of it."""
    line = upper_boundary(polygon)
    line = line[np.r_[True, (np.diff(line, axis=0) != 0.0).any(axis=1)]]  # a point once where y_top is continuous
    x, y = line[:, 0], line[:, 1]
    higher_than_neighbours = np.ones(len(line), dtype=bool)
    higher_than_neighbours[1:] &= y[1:] >= y[:-1]
    higher_than_neighbours[:-1] &= y[:-1] >= y[1:]
    peaks = np.flatnonzero(higher_than_neighbours)
    # segment s runs from point s to s + 1; those within width_m of a peak: first[k] ... first[k] + counts[k] - 1
    first = np.searchsorted(x[1:], x[peaks] - width_m, side="left")
    counts = np.maximum(np.searchsorted(x[:-1], x[peaks] + width_m, side="right") - first, 0)
    # bounded by the ends of the boundary within width_m, else at least width_m away on that side
    left = np.where(x[0] > x[peaks] - width_m, x[0], -np.inf)
    right = np.where(x[-1] < x[peaks] + width_m, x[-1], np.inf)
    for k0, k1 in _batches(counts):
        k = np.repeat(np.arange(k0, k1), counts[k0:k1])
        s = _ranges(first[k0:k1], counts[k0:k1])
        level = y[peaks[k]] - width_m
        crosses = (y[s] >= level) != (y[s + 1] >= level)
        k, s, level = k[crosses], s[crosses], level[crosses]
        x_cross = x[s] + (level - y[s]) / (y[s + 1] - y[s]) * (x[s + 1] - x[s])
        before = s < peaks[k]  # the segments before the peak's point bound it on the left
        np.maximum.at(left, k[before], x_cross[before])
        np.minimum.at(right, k[~before], x_cross[~before])
    narrow = np.flatnonzero(right - left < width_m)
    narrow = narrow[np.argsort(-y[peaks[narrow]], kind="stable")]
    return np.column_stack([x[peaks[narrow]], y[peaks[narrow]], (right - left)[narrow]])


def relief_m(polygon) -> float:
    """The relief of the upper boundary: its highest minus its lowest point (a slope's height, crest
    above toe; the ground below the toe does not count); the polygon's height when the upper
    boundary is flat."""
    heights = upper_boundary_heights(polygon)
    relief = max(heights) - min(heights) if heights else 0.0
    if relief > 0.0:
        return relief
    ys = vertices_m(polygon)[:, 1]
    return float(ys.max() - ys.min())


def downslope_sign(polygon) -> float | None:
    """+1 when the upper boundary is lower at the right end of the polygon than at the left, -1 when
    it is lower at the left, None when both ends are as high."""
    xs = vertices_m(polygon)[:, 0]
    left, right = surface_height_m(polygon, np.array([xs.min(), xs.max()]))
    if math.isclose(left, right, rel_tol=0.0, abs_tol=1e-9 * (1.0 + abs(left))):
        return None
    return 1.0 if right < left else -1.0
