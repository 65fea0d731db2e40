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
