"""Particle clouds: counts, spacing, boundary particles, jitter, validation."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from spfem_core.cloud import particles_in_polygon
from spfem_core.geometry import points_in_polygon

pytestmark = pytest.mark.filterwarnings("error")

BEAM = np.array([(0.0, 0.0), (2.0, 0.0), (2.0, 0.2), (0.0, 0.2)])
SLOPE = np.array([(0.0, 0.0), (60.0, 0.0), (60.0, 5.0), (40.0, 5.0), (20.0, 15.0), (0.0, 15.0)])


def nearest_neighbour_distance_m(node_xy_m):
    """Distance from every particle to its nearest other particle."""
    distance_m, _ = cKDTree(node_xy_m).query(node_xy_m, k=2)
    return distance_m[:, 1]


def distance_to_segment_m(points, a, b):
    """|p - a - clip(t, 0, 1)(b - a)|, t = (p - a).(b - a)/|b - a|^2."""
    ab = b - a
    t = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
    return np.hypot(*(points - a - t[:, None] * ab).T)


def distance_to_boundary_m(points, polygon):
    """Distance from each point to the nearest edge of the polygon."""
    edges = zip(polygon, np.roll(polygon, -1, axis=0))
    return np.min([distance_to_segment_m(points, a, b) for a, b in edges], axis=0)


def test_beam_cloud_is_the_lattice():
    h = 0.02
    node_xy_m = particles_in_polygon(BEAM, h)
    assert node_xy_m.shape == (1111, 2)
    assert node_xy_m.dtype == np.float64 and node_xy_m.flags.c_contiguous
    assert points_in_polygon(node_xy_m, BEAM).all()
    assert nearest_neighbour_distance_m(node_xy_m).min() >= 0.5 * h
    lattice_index = np.round(node_xy_m / h)
    np.testing.assert_allclose(node_xy_m, lattice_index * h, atol=1e-12)
    assert len(np.unique(lattice_index, axis=0)) == 1111


@pytest.mark.parametrize("h", [1.0, 0.5, 0.3])
def test_slope_cloud(h):
    node_xy_m = particles_in_polygon(SLOPE, h)
    assert points_in_polygon(node_xy_m, SLOPE).all()
    assert nearest_neighbour_distance_m(node_xy_m).min() >= 0.45 * h
    tree = cKDTree(node_xy_m)
    vertex_distance_m, _ = tree.query(SLOPE)
    assert vertex_distance_m.max() < 1e-12  # every polygon vertex is a particle
    on_any_edge = np.zeros(len(node_xy_m), dtype=bool)
    for a, b in zip(SLOPE, np.roll(SLOPE, -1, axis=0)):
        on_edge = distance_to_segment_m(node_xy_m, a, b) < 1e-9
        n_segments = int(np.ceil(np.hypot(*(b - a)) / h - 1e-9))
        assert on_edge.sum() == n_segments + 1  # ceil(L/h) equal segments, both ends
        on_any_edge |= on_edge
    # interior particles keep h/2 from the boundary
    interior = node_xy_m[~on_any_edge]
    assert distance_to_boundary_m(interior, SLOPE).min() >= 0.5 * h * (1 - 1e-9)


def test_orientation_and_closed_ring_do_not_matter():
    h = 0.5
    reference = particles_in_polygon(SLOPE, h)
    for polygon in (SLOPE[::-1], np.vstack([SLOPE, SLOPE[:1]]), np.roll(SLOPE, 2, axis=0)):
        other = particles_in_polygon(polygon, h)
        assert other.shape == reference.shape
        distance_m, _ = cKDTree(reference).query(other)
        assert distance_m.max() < 1e-12


@pytest.mark.parametrize("extra", [(30.0, 10.0), (37.25, 6.375), (27.3, 0.0)])
def test_a_vertex_in_the_middle_of_a_straight_side_adds_no_particle(extra):
    """A redundant vertex used to split its side in two, one particle more (and the FOS moved by a
    bracket); the cloud is now that of the polygon without it, particle for particle."""
    reference = particles_in_polygon(SLOPE, 1.0)
    on_side = [np.isclose(np.hypot(*(p - a)) + np.hypot(*(b - p)), np.hypot(*(b - a)), rtol=1e-12)
               for a, b, p in zip(SLOPE, np.roll(SLOPE, -1, axis=0), [np.array(extra)] * len(SLOPE))]
    side = on_side.index(True)
    polygon = np.insert(SLOPE, side + 1, extra, axis=0)
    np.testing.assert_array_equal(particles_in_polygon(polygon, 1.0), reference)
    np.testing.assert_array_equal(particles_in_polygon(np.roll(polygon, -(side + 1), axis=0), 1.0), reference)


def test_neighbours_are_close_in_memory():
    node_xy_m = particles_in_polygon(SLOPE, 0.5)
    pairs = cKDTree(node_xy_m).query_pairs(1.01 * 0.5, output_type="ndarray")
    index_gap = np.abs(pairs[:, 0] - pairs[:, 1])
    # random order would give a median gap of about n/3
    assert np.median(index_gap) < len(node_xy_m) / 50


def test_jitter_reproducible_and_bounded():
    h, jitter = 0.5, 0.25
    plain = particles_in_polygon(SLOPE, h)
    first = particles_in_polygon(SLOPE, h, jitter=jitter, seed=7)
    np.testing.assert_array_equal(first, particles_in_polygon(SLOPE, h, jitter=jitter, seed=7))
    assert not np.array_equal(first, particles_in_polygon(SLOPE, h, jitter=jitter, seed=8))
    assert first.shape == plain.shape
    # every particle moved by at most jitter h per coordinate, one-to-one
    shift_m, origin = cKDTree(plain).query(first, p=np.inf)
    assert shift_m.max() <= jitter * h
    assert len(np.unique(origin)) == len(plain)
    # boundary particles do not move, all stay inside
    on_boundary = distance_to_boundary_m(plain, SLOPE) < 1e-9
    moved = shift_m[np.argsort(origin)] > 0.0
    assert not moved[on_boundary].any()
    assert moved[~on_boundary].all()
    assert points_in_polygon(first, SLOPE).all()


@pytest.mark.parametrize(
    "kwargs, argument",
    [
        (dict(polygon_m=[(0, 0), (1, 0)], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=[(0, 0), (1, 0), (1, 0), (0, 1)], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=[(0, 0), (1, 1), (1, 0), (0, 1)], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=[(0, 0), (1, 0), (2, 0)], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=[(0, 0), (1, 0), (np.nan, 1)], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=[0, 1, 2], spacing_m=0.1), "polygon_m"),
        (dict(polygon_m=BEAM, spacing_m=0.0), "spacing_m"),
        (dict(polygon_m=BEAM, spacing_m=-0.1), "spacing_m"),
        (dict(polygon_m=BEAM, spacing_m=np.inf), "spacing_m"),
        (dict(polygon_m=BEAM, spacing_m="a"), "spacing_m"),
        (dict(polygon_m=BEAM, spacing_m=0.1, jitter=0.3), "jitter"),
        (dict(polygon_m=BEAM, spacing_m=0.1, jitter=-0.01), "jitter"),
    ],
)
def test_bad_input_names_the_argument(kwargs, argument):
    with pytest.raises(ValueError, match=argument):
        particles_in_polygon(**kwargs)


def test_points_in_polygon():
    points = np.array(
        [
            (10.0, 7.0),  # inside
            (40.0, 8.0),  # in the concave notch: outside
            (50.0, 10.0),  # in the notch, inside the convex hull: outside
            (-1.0, 7.0),  # left of the polygon
            (30.0, 10.0),  # on the slope face
            (40.0, 5.0),  # the toe, a vertex
            (50.0, 5.0),  # on the horizontal edge y = 5
            (0.0, 15.0),  # a corner
            (60.0, 2.5),  # on the right edge
            (61.0, 2.5),  # right of the polygon
            (30.0, 10.0 + 1e-6),  # just outside the slope face
        ]
    )
    expected = [True, False, False, False, True, True, True, True, True, False, False]
    np.testing.assert_array_equal(points_in_polygon(points, SLOPE), expected)
    np.testing.assert_array_equal(points_in_polygon(points, SLOPE[::-1]), expected)
    with pytest.raises(ValueError, match="points"):
        points_in_polygon(np.zeros(3), SLOPE)
