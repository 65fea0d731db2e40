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


def _segments_touch(p0, p1, q0, q1, tol_m: float) -> bool:
    """True when the segments p0-p1 and q0-q1 cross or come within ``tol_m`` of each other."""

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    d1, d2 = cross(q0, q1, p0), cross(q0, q1, p1)
    d3, d4 = cross(p0, p1, q0), cross(p0, p1, q1)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return True  # a proper crossing
    gap = min(distance_to_edges_m([p0, p1], [q0, q1], closed=False).min(),
              distance_to_edges_m([q0, q1], [p0, p1], closed=False).min())
    return gap <= tol_m


def first_self_intersection(polygon) -> tuple[int, int] | None:
    """The first pair (i, j) of non-adjacent edges that cross or touch (edge i runs from vertex i
    to vertex i + 1); None for a simple polygon.  O(m^2): polygons are small."""
    xy = vertices_m(polygon)
    m = xy.shape[0]
    end = np.roll(xy, -1, axis=0)
    tol = ON_EDGE_REL_TOL * size_m(xy)
    for i in range(m):
        for j in range(i + 2, m):
            if i == 0 and j == m - 1:
                continue  # adjacent through the closing vertex
            if _segments_touch(xy[i], end[i], xy[j], end[j], tol):
                return i, j
    return None


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


def surface_height_m(polygon, x) -> np.ndarray:
    """y_top(x): the height of the polygon's highest edge above each abscissa ``x`` (NaN where none)."""
    xy = vertices_m(polygon)
    start, end = xy, np.roll(xy, -1, axis=0)
    x = np.asarray(x, dtype=np.float64)[:, None]
    lo, hi = np.minimum(start[:, 0], end[:, 0]), np.maximum(start[:, 0], end[:, 0])
    spans = (x >= lo) & (x <= hi) & (hi > lo)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (x - start[:, 0]) / (end[:, 0] - start[:, 0])
        y = start[:, 1] + t * (end[:, 1] - start[:, 1])
    y = np.where(spans, y, -np.inf).max(axis=1)
    return np.where(np.isfinite(y), y, np.nan)


def upper_boundary_heights(polygon) -> list[float]:
    """Heights of the upper boundary y_top(x), the largest y of the boundary at x, at every vertex
    abscissa, approached from the left and from the right (where y_top, piecewise linear with
    jumps at vertical edges, takes its extreme values)."""
    vertices = [tuple(v) for v in vertices_m(polygon).tolist()]
    edges = [(a, b) if a[0] <= b[0] else (b, a) for a, b in zip(vertices, vertices[1:] + vertices[:1])]
    heights = []
    for x0 in sorted({x for x, _ in vertices}):
        left, right = [], []
        for (x1, y1), (x2, y2) in edges:
            if x1 == x2 or not x1 <= x0 <= x2:
                continue  # vertical edges are seen through their neighbours
            y = y1 if x0 == x1 else y2 if x0 == x2 else y1 + (x0 - x1) * (y2 - y1) / (x2 - x1)
            if x1 < x0:
                left.append(y)
            if x2 > x0:
                right.append(y)
        heights += [max(side) for side in (left, right) if side]
    return heights


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
