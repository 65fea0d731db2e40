"""Alpha-shape triangulation: orientation, areas, concave boundaries, CSR adjacency."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spfem_core.cloud import particles_in_polygon
from spfem_core.geometry import points_in_polygon
from spfem_core.mesh import (
    Mesh,
    count_inverted,
    delaunay_triangles,
    element_quality_min_angle,
    mesh_from_elements,
    triangulate,
)
from verification.probes import all_corners_min_angle

pytestmark = pytest.mark.filterwarnings("error")

BEAM = np.array([(0.0, 0.0), (2.0, 0.0), (2.0, 0.2), (0.0, 0.2)])
SLOPE = np.array([(0.0, 0.0), (60.0, 0.0), (60.0, 5.0), (40.0, 5.0), (20.0, 15.0), (0.0, 15.0)])
SLOPE_AREA_M2 = 600.0
NOTCH = np.array([(40.0, 5.0), (60.0, 5.0), (20.0, 15.0)])
"""Outside the slope polygon but inside its convex hull."""


def signed_area_m2(node_xy_m, elem_nodes):
    """A = ((x1 - x0)(y2 - y0) - (x2 - x0)(y1 - y0)) / 2 per triangle."""
    p0, p1, p2 = (node_xy_m[elem_nodes[:, k]] for k in range(3))
    return 0.5 * ((p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p2[:, 0] - p0[:, 0]) * (p1[:, 1] - p0[:, 1]))


def assert_csr_consistent(mesh: Mesh):
    """Types, pointer shapes, node->element membership, sorted symmetric node->node."""
    n = mesh.n_nodes
    for name in ("elem_nodes", "node_elem_ptr", "node_elem_idx", "node_node_ptr", "node_node_idx"):
        array = getattr(mesh, name)
        assert array.dtype == np.int64 and array.flags.c_contiguous, name
    for ptr, idx in ((mesh.node_elem_ptr, mesh.node_elem_idx), (mesh.node_node_ptr, mesh.node_node_idx)):
        assert ptr.shape == (n + 1,) and ptr[0] == 0 and ptr[-1] == len(idx)
        assert np.all(np.diff(ptr) >= 0)

    # node -> element holds exactly the pairs (vertex of e, e)
    row = np.repeat(np.arange(n), np.diff(mesh.node_elem_ptr))
    from_csr = set(zip(row.tolist(), mesh.node_elem_idx.tolist()))
    from_elements = {(int(v), e) for e, nodes in enumerate(mesh.elem_nodes) for v in nodes}
    assert from_csr == from_elements and len(from_csr) == 3 * mesh.n_elem

    # node -> node: ascending rows, no self, symmetric, the undirected edges of the triangles
    row = np.repeat(np.arange(n), np.diff(mesh.node_node_ptr))
    column = mesh.node_node_idx
    assert np.all(row != column)
    same_row = row[1:] == row[:-1]
    assert np.all(column[1:][same_row] > column[:-1][same_row])
    directed = set(zip(row.tolist(), column.tolist()))
    assert directed == {(j, i) for i, j in directed}
    edges = {frozenset((int(t[a]), int(t[b]))) for t in mesh.elem_nodes for a, b in ((0, 1), (1, 2), (2, 0))}
    assert {frozenset(pair) for pair in directed} == edges
    assert np.diff(mesh.node_node_ptr).sum() == 2 * len(edges)


@pytest.fixture(scope="module")
def beam():
    h = 0.02
    node_xy_m = particles_in_polygon(BEAM, h)
    return node_xy_m, h, triangulate(node_xy_m, h)


def test_beam_mesh(beam):
    node_xy_m, h, mesh = beam
    area_m2 = signed_area_m2(node_xy_m, mesh.elem_nodes)
    assert area_m2.min() > 0.0
    assert count_inverted(node_xy_m, mesh.elem_nodes) == 0
    assert area_m2.sum() == pytest.approx(2.0 * 0.2, rel=1e-10)
    assert len(mesh.orphan_nodes) == 0
    assert mesh.n_elem == 2 * 100 * 10
    assert np.degrees(element_quality_min_angle(node_xy_m, mesh.elem_nodes)) == pytest.approx(45.0, abs=1e-9)
    assert_csr_consistent(mesh)


def test_rectangle_loses_nothing_to_the_alpha_filter(beam):
    node_xy_m, h, mesh = beam
    everything = delaunay_triangles(node_xy_m)
    non_degenerate = np.abs(signed_area_m2(node_xy_m, everything)) > 1e-12 * h * h
    assert mesh.n_elem == non_degenerate.sum()
    kept = {tuple(sorted(t)) for t in mesh.elem_nodes.tolist()}
    assert kept == {tuple(sorted(t)) for t in everything[non_degenerate].tolist()}


@pytest.mark.parametrize("h", [1.0, 0.5])
@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_slope_alpha_shape_recovers_the_concave_boundary(h, jitter):
    node_xy_m = particles_in_polygon(SLOPE, h, jitter=jitter, seed=1)
    mesh = triangulate(node_xy_m, h)
    centroid_m = node_xy_m[mesh.elem_nodes].mean(axis=1)
    assert not points_in_polygon(centroid_m, NOTCH, tol_m=0.0).any()
    # plain Delaunay does fill the notch: the filter did the work
    everything = delaunay_triangles(node_xy_m)
    assert points_in_polygon(node_xy_m[everything].mean(axis=1), NOTCH, tol_m=0.0).any()
    area_m2 = signed_area_m2(node_xy_m, mesh.elem_nodes)
    assert area_m2.min() > 0.0
    assert area_m2.sum() == pytest.approx(SLOPE_AREA_M2, rel=1e-9)
    assert len(mesh.orphan_nodes) == 0
    assert_csr_consistent(mesh)


@pytest.mark.parametrize("offset_m", [(1e7, 0.0), (-3e6, 2e6), (5e8, -5e8)])
def test_survey_coordinates_mesh_like_the_section_at_the_origin(offset_m):
    """Qhull's precision tests scale with the coordinates: at 1e7 m (h = 1 m) it used to drop a
    third of the triangles.  From an exact local origin the far cloud meshes like the near one."""
    h = 1.0
    node_xy_m = particles_in_polygon(SLOPE, h)
    far_xy_m = node_xy_m + np.array(offset_m)
    near, far = triangulate(node_xy_m, h), triangulate(far_xy_m, h)
    assert far.elem_nodes.shape == near.elem_nodes.shape
    assert len(far.orphan_nodes) == 0
    assert signed_area_m2(far_xy_m - np.array(offset_m), far.elem_nodes).sum() == pytest.approx(SLOPE_AREA_M2, rel=1e-9)


def test_alpha_filter_separates_detached_blocks_and_reports_orphans():
    h = 0.1
    left = particles_in_polygon([(0, 0), (1, 0), (1, 1), (0, 1)], h)
    right = particles_in_polygon([(1.5, 0), (2.5, 0), (2.5, 1), (1.5, 1)], h)
    lonely = np.array([[1.25, 3.0]])
    node_xy_m = np.vstack([left, right, lonely])
    mesh = triangulate(node_xy_m, h)
    assert signed_area_m2(node_xy_m, mesh.elem_nodes).sum() == pytest.approx(2.0, rel=1e-10)
    np.testing.assert_array_equal(mesh.orphan_nodes, [len(node_xy_m) - 1])
    assert_csr_consistent(mesh)


def test_min_angle_and_inverted_elements():
    node_xy_m = np.array([(0.0, 0.0), (1.0, 0.0), (0.5, np.sqrt(0.75)), (1.5, np.sqrt(0.75))])
    elem_nodes = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)
    assert np.degrees(element_quality_min_angle(node_xy_m, elem_nodes)) == pytest.approx(60.0)
    assert count_inverted(node_xy_m, elem_nodes) == 0
    flipped = elem_nodes.copy()
    flipped[1] = flipped[1, [0, 2, 1]]
    assert count_inverted(node_xy_m, flipped) == 1
    moved = node_xy_m.copy()
    moved[3] = (0.5, 0.2)  # node 3 crosses edge 1-2: element 1 turns inside out
    assert count_inverted(moved, elem_nodes) == 1
    moved[2] = (0.5, 0.0)  # collinear: zero area counts as inverted
    assert count_inverted(moved, elem_nodes[:1]) == 1
    assert element_quality_min_angle(node_xy_m, elem_nodes[:0]) == pytest.approx(np.pi)


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # numba compiling the reference kernel
@settings(deadline=None, max_examples=60, database=None)
@given(
    jitter=st.floats(0.0, 0.29),
    shear=st.floats(-3.0, 3.0),
    squash=st.floats(0.05, 1.0),
    pinch=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_min_angle_equals_the_all_corner_minimum_to_the_bit(jitter, shear, squash, pinch, seed):
    """The single-pass check (sine proxy, atan2 only near the minimum) against the plain
    definition, on lattices (thousands of equal angles), jittered clouds, then the same
    meshes sheared and squashed with one particle pulled towards a neighbour (near-degenerate)."""
    node_xy_m = particles_in_polygon(SLOPE, 1.0, jitter=jitter, seed=seed)
    elem_nodes = triangulate(node_xy_m, 1.0).elem_nodes
    for xy in (node_xy_m, node_xy_m @ np.array([[1.0, 0.0], [shear, squash]])):
        xy = xy.copy()
        a, b = elem_nodes[seed % len(elem_nodes), :2]
        xy[a] += pinch * (xy[b] - xy[a])
        assert element_quality_min_angle(xy, elem_nodes) == all_corners_min_angle(xy, elem_nodes)
    # two vertices at one point: a flat triangle.  Its corners measure 0 or pi where a side is
    # the zero vector (atan2(0, +-0): the sign of the zero dot product decides) and about
    # 1e-18 rad at the third (u = v, and |u x v| is a rounding residue), not always exactly 0
    xy[elem_nodes[0, 0]] = xy[elem_nodes[0, 1]]
    flat = element_quality_min_angle(xy, elem_nodes)
    assert flat == all_corners_min_angle(xy, elem_nodes) and 0.0 <= flat < 1e-12
    xy[elem_nodes[-1, 2], 1] = np.nan
    assert np.isnan(element_quality_min_angle(xy, elem_nodes))


def test_mesh_is_frozen(beam):
    _, _, mesh = beam
    with pytest.raises(dataclasses.FrozenInstanceError):
        mesh.n_nodes = 3


def test_mesh_from_elements_small():
    mesh = mesh_from_elements(np.array([[0, 1, 2], [1, 3, 2]]), 5)
    np.testing.assert_array_equal(mesh.node_elem_ptr, [0, 1, 3, 5, 6, 6])
    np.testing.assert_array_equal(mesh.node_elem_idx, [0, 0, 1, 0, 1, 1])
    np.testing.assert_array_equal(mesh.node_node_ptr, [0, 2, 5, 8, 10, 10])
    np.testing.assert_array_equal(mesh.node_node_idx, [1, 2, 0, 2, 3, 0, 1, 3, 1, 2])
    np.testing.assert_array_equal(mesh.orphan_nodes, [4])


@pytest.mark.parametrize(
    "args, argument",
    [
        ((np.zeros((5, 3)), 0.1), "node_xy_m"),
        ((np.zeros((2, 2)), 0.1), "node_xy_m"),
        ((np.array([[0, 0], [1, 0], [np.nan, 1]]), 0.1), "node_xy_m"),
        ((np.array([[0, 0], [1, 0], [0, 1]]), 0.0), "spacing_m"),
        ((np.array([[0, 0], [1, 0], [0, 1]]), 1.0, -1.0), "alpha"),
    ],
)
def test_bad_input_names_the_argument(args, argument):
    with pytest.raises(ValueError, match=argument):
        triangulate(*args)


@settings(deadline=None, max_examples=30, database=None)
@given(
    width_h=st.floats(2.0, 30.0),
    height_h=st.floats(2.0, 15.0),
    log10_h=st.floats(-3.0, 1.0),
    origin_h=st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)),
    jitter=st.floats(0.0, 0.29),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_jittered_rectangles(width_h, height_h, log10_h, origin_h, jitter, seed):
    h = 10.0**log10_h
    x0, y0 = origin_h[0] * h, origin_h[1] * h
    width_m, height_m = width_h * h, height_h * h
    rectangle = [(x0, y0), (x0 + width_m, y0), (x0 + width_m, y0 + height_m), (x0, y0 + height_m)]
    node_xy_m = particles_in_polygon(rectangle, h, jitter=jitter, seed=seed)
    mesh = triangulate(node_xy_m, h)
    area_m2 = signed_area_m2(node_xy_m, mesh.elem_nodes)
    assert area_m2.min() > 0.0
    assert count_inverted(node_xy_m, mesh.elem_nodes) == 0
    assert area_m2.sum() == pytest.approx(width_m * height_m, rel=1e-9)
    assert len(mesh.orphan_nodes) == 0
    assert_csr_consistent(mesh)


@pytest.mark.parametrize("shuffle", [False, True])
def test_blocks_of_one_colour_share_no_node(shuffle):
    """mesh.coloured_blocks: the element and edge blocks cover every element and edge once, in
    order, every block has one colour, and blocks of one colour touch no common particle; also
    when the particle numbers are shuffled (elements then spread over all node numbers)."""
    xy = particles_in_polygon([[0.0, 0.0], [6.0, 0.0], [6.0, 3.0], [0.0, 3.0]], 0.05, jitter=0.2, seed=3)
    if shuffle:
        xy = xy[np.random.default_rng(5).permutation(len(xy))]
    mesh = triangulate(xy, 0.05)
    for items, ptr, colour_ptr, colour_block in (
        (mesh.elem_nodes, mesh.elem_block_ptr, mesh.elem_colour_ptr, mesh.elem_colour_block),
        (mesh.edge_nodes, mesh.edge_block_ptr, mesh.edge_colour_ptr, mesh.edge_colour_block),
    ):
        assert ptr[0] == 0 and ptr[-1] == len(items) and np.all(np.diff(ptr) > 0)
        assert sorted(colour_block.tolist()) == list(range(len(ptr) - 1))
        for c in range(len(colour_ptr) - 1):
            seen = set()
            for block in colour_block[colour_ptr[c]:colour_ptr[c + 1]]:
                nodes = set(items[ptr[block]:ptr[block + 1]].ravel().tolist())
                assert not nodes & seen, (c, block)
                seen |= nodes
        if not shuffle:  # space-ordered particles: a handful of colours, many blocks in each
            assert len(colour_ptr) - 1 <= 6 and (len(ptr) - 1) / (len(colour_ptr) - 1) >= 4
