"""Plane geometry of polygons and the ground surface (spfem_core.geometry): what the study reader,
the cloud, the memory guard, the loads and the runout metrics share."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from spfem_core import geometry

SQUARE = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
SLOPE = ((0.0, 0.0), (60.0, 0.0), (60.0, 5.0), (40.0, 5.0), (20.0, 15.0), (0.0, 15.0))
"""The reference slope: 10 m high at 1V:2H on a 5 m foundation, crest on the left."""


def test_points_on_the_boundary_count_as_inside():
    inside = geometry.points_in_polygon([(0.5, 0.5), (1.0, 1.0), (0.5, 0.0), (1.001, 0.5), (-0.5, -0.5)], SQUARE)
    np.testing.assert_array_equal(inside, [True, True, True, False, False])
    concave = geometry.points_in_polygon([(30.0, 10.0), (40.0, 10.0)], SLOPE)
    np.testing.assert_array_equal(concave, [True, False])


def test_area_and_perimeter_by_the_shoelace_formula():
    assert geometry.signed_area_m2(SQUARE) == 1.0
    assert geometry.signed_area_m2(SQUARE[::-1]) == -1.0  # clockwise
    # the slope: a 60 x 5 foundation, a 20 x 10 block behind the crest and the 20 x 10 triangle of the face
    assert geometry.signed_area_m2(SLOPE) == pytest.approx(300.0 + 200.0 + 100.0)
    assert geometry.perimeter_m(SQUARE) == 4.0


@pytest.mark.parametrize("vertices, problem", [
    (((0.0, 0.0), (1.0, 0.0)), "at least 3 vertices, got 2"),
    (((0.0, 0.0), (1.0, 0.0), (2.0, 0.0)), "zero area"),
    (((0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)), "edges 0 and 2 cross"),
    (((0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0)), "vertices 1 and 2 coincide"),
    (((0.0, 0.0), (1.0, 0.0), (np.nan, 1.0)), "finite"),
])
def test_polygon_problems_are_named(vertices, problem):
    assert problem in geometry.polygon_problem(vertices)


def test_a_simple_polygon_has_no_problem():
    assert geometry.polygon_problem(SLOPE) is None and geometry.polygon_problem(SLOPE[::-1]) is None


def test_surface_height_relief_and_downslope_side_of_a_slope():
    heights = geometry.surface_height_m(SLOPE, np.array([0.0, 10.0, 30.0, 40.0, 50.0, 70.0]))
    np.testing.assert_allclose(heights[:5], [15.0, 15.0, 10.0, 5.0, 5.0])
    assert np.isnan(heights[5])  # beyond the domain
    assert geometry.relief_m(SLOPE) == 10.0  # crest above toe: the foundation does not count
    assert geometry.relief_m(SQUARE) == 1.0  # a flat top: the polygon's height
    assert geometry.downslope_sign(SLOPE) == 1.0
    assert geometry.downslope_sign([(x, y) for x, y in ((60.0 - x, y) for x, y in SLOPE)]) == -1.0
    assert geometry.downslope_sign(SQUARE) is None


def test_geometry_and_settings_import_no_numba():
    """The study reader imports them before anything compiles (about 1 s saved on a bad study file)."""
    code = ("import sys, spfem_core.geometry, spfem_core.settings, workflows.study; "
            "print('numba' in sys.modules, 'xarray' in sys.modules, 'scipy' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["False", "False", "False"]


def _touching_pairs_by_brute_force(xy) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges that cross or touch, every pair tested in turn."""
    m, tol = len(xy), geometry.ON_EDGE_REL_TOL * geometry.size_m(xy)
    for i in range(m):
        for j in range(i + 2, m):
            if not (i == 0 and j == m - 1):
                p, q = np.array([xy[i], xy[(i + 1) % m]]), np.array([xy[j], xy[(j + 1) % m]])
                if geometry._segments_touch(p[:1], p[1:], q[:1], q[1:], tol)[0]:
                    return i, j
    return None


def _upper_boundary_by_brute_force(xy) -> list[float]:
    edges = [(a, b) if a[0] <= b[0] else (b, a) for a, b in zip(xy, xy[1:] + xy[:1])]
    heights = []
    for x0 in sorted({x for x, _ in xy}):
        left, right = [], []
        for (x1, y1), (x2, y2) in edges:
            if x1 < x2 and x1 <= x0 <= x2:
                y = y1 if x0 == x1 else y2 if x0 == x2 else y1 + (x0 - x1) * (y2 - y1) / (x2 - x1)
                (left.append(y) if x1 < x0 else None), (right.append(y) if x2 > x0 else None)
        heights += [max(side) for side in (left, right) if side]
    return heights


@pytest.mark.parametrize("pairs_per_batch", [geometry.PAIRS_PER_BATCH, 2])
def test_the_sweeps_find_what_testing_every_pair_finds(monkeypatch, pairs_per_batch):
    """Random polygons, many of them on an integer grid (touching, collinear and vertical edges):
    the first crossing, the upper boundary, y_top(x) and the points near an edge as every pair of
    edges gives them, in batches of any size."""
    monkeypatch.setattr(geometry, "PAIRS_PER_BATCH", pairs_per_batch)
    rng = np.random.default_rng(7)
    crossings = 0
    for trial in range(400):
        m = int(rng.integers(3, 12))
        xy = rng.integers(0, 5, size=(m, 2)).astype(float) if trial % 2 else rng.normal(size=(m, 2))
        if len(np.unique(xy, axis=0)) < m:
            continue
        polygon = [tuple(v) for v in xy.tolist()]
        expected = _touching_pairs_by_brute_force(polygon)
        crossings += expected is not None
        assert geometry.first_self_intersection(polygon) == expected
        assert geometry.upper_boundary_heights(polygon) == _upper_boundary_by_brute_force(polygon)
        x = np.concatenate([rng.uniform(-3.0, 6.0, 10), xy[:, 0]])
        edges = list(zip(polygon, polygon[1:] + polygon[:1]))
        top = [max([y1 + (x0 - x1) / (x2 - x1) * (y2 - y1) for (x1, y1), (x2, y2) in edges
                    if min(x1, x2) <= x0 <= max(x1, x2) and x1 != x2], default=np.nan) for x0 in x]
        np.testing.assert_array_equal(geometry.surface_height_m(polygon, x), top)
        points = np.vstack([rng.uniform(-1.0, 5.0, (40, 2)), rng.integers(-1, 6, (20, 2)) / 2.0])
        for distance_m in (0.01, 0.5, 2.0):
            np.testing.assert_array_equal(geometry.points_near_edges(points, polygon, distance_m),
                                          geometry.distance_to_edges_m(points, polygon) < distance_m)
    assert crossings > 100


def test_a_surveyed_ground_line_of_10000_points_is_checked_at_once():
    """The simplicity test and the upper boundary were quadratic in pure Python (2,000 points: 117 s);
    a crossing near the end of the line is still named by its edges."""
    import time

    rng = np.random.default_rng(0)
    x = np.linspace(20.0, 70.0, 10_000)
    ground = np.column_stack([x, np.interp(x, [20, 30, 50, 70], [25, 25, 35, 35]) + rng.normal(0.0, 0.02, x.size)])
    polygon = [(20.0, 20.0), (70.0, 20.0), *map(tuple, ground[::-1].tolist())]
    start = time.perf_counter()
    assert geometry.polygon_problem(polygon) is None
    assert geometry.relief_m(polygon) == pytest.approx(10.0, abs=0.2)
    assert np.isfinite(geometry.surface_height_m(polygon, rng.uniform(20.0, 70.0, 100_000))).all()
    assert time.perf_counter() - start < 2.0
    polygon[5:7] = [(69.9, 40.0), (69.9, 10.0)]  # a spike down through the base, near the right end
    assert "edges 0 and 5 cross" in geometry.polygon_problem(polygon)


def _section(ground, base_y_m=-5.0):
    return [(ground[0][0], base_y_m), (ground[-1][0], base_y_m), *ground[::-1]]


@pytest.mark.parametrize("ground, narrow", [
    ([(0.0, 0.0), (10.0, 10.0), (20.0, 0.0)], []),  # a 1:1 ridge: 2 m wide 1 m below its top
    ([(0.0, 0.0), (10.0, 19.9), (20.0, 0.0)], []),  # 20 / 19.9 m wide 1 m below its top
    ([(0.0, 0.0), (10.0, 30.0), (20.0, 0.0)], [(10.0, 30.0, 2.0 / 3.0)]),  # flanks at 3:1
    ([(0.0, 0.0), (5.0, 0.0), (5.2, 100.0), (5.4, 0.0), (9.0, 0.0)], [(5.2, 100.0, 0.004)]),  # a spike
    ([(0.0, 30.0), (0.5, 0.0), (20.0, 0.0)], [(0.0, 30.0, 1.0 / 60.0)]),  # at the end of the boundary
    ([(0.0, 10.0), (20.0, 10.0)], []),  # flat: the ends are no peaks
])
def test_narrow_peaks_are_those_narrower_than_the_width_one_width_below_their_top(ground, narrow):
    np.testing.assert_allclose(geometry.narrow_peaks(_section(ground), 1.0).reshape(-1, 3), np.reshape(narrow, (-1, 3)))


def test_a_peak_wider_than_its_own_width_is_narrow_only_for_a_wider_one():
    """A flat-topped spike 0.2 m wide: narrow at 0.3 m, not at 0.05 m (a wedge is narrow at any width)."""
    spike = _section([(0.0, 0.0), (5.0, 0.0), (5.1, 2.0), (5.3, 2.0), (5.4, 0.0), (9.0, 0.0)])
    assert geometry.narrow_peaks(spike, 0.3).shape[0] > 0 and geometry.narrow_peaks(spike, 0.05).shape[0] == 0
    wedge = _section([(0.0, 0.0), (5.0, 0.0), (5.2, 2.0), (5.4, 0.0), (9.0, 0.0)])
    assert geometry.narrow_peaks(wedge, 0.3).shape[0] > 0 and geometry.narrow_peaks(wedge, 0.05).shape[0] > 0
