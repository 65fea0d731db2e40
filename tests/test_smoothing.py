"""Patch tests of the node-based strain smoothing and its internal force."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.cloud import particles_in_polygon
from spfem_core.mesh import triangulate
from spfem_core.nodal_force import assemble_nodal_force
from verification.probes import smoothed_gradient

SLOPE_POLYGON = [[0, 0], [60, 0], [60, 5], [40, 5], [20, 15], [0, 15]]


def _polygon_area(polygon):
    p = np.asarray(polygon, dtype=float)
    return 0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))


@pytest.mark.parametrize(
    "polygon, spacing, jitter",
    [([[0, 0], [2, 0], [2, 0.2], [0, 0.2]], 0.02, 0.25), (SLOPE_POLYGON, 1.0, 0.2), (SLOPE_POLYGON, 0.5, 0.0)],
)
def test_linear_velocity_gives_exact_gradient_everywhere(polygon, spacing, jitter):
    """v = a + G x must give L_k = G at every particle, boundary ones included (patch test)."""
    xy = particles_in_polygon(polygon, spacing, jitter=jitter, seed=3)
    mesh = triangulate(xy, spacing)
    G = np.array([[0.3, -1.7], [2.1, 0.4]])
    v = np.array([0.5, -0.25]) + xy @ G.T
    L, area = smoothed_gradient(xy, v, mesh.elem_nodes)
    expected = np.broadcast_to(G.reshape(4), L.shape)  # (xx, xy, yx, yy) = row-major G
    assert np.all(area > 0)
    np.testing.assert_allclose(L, expected, rtol=0, atol=1e-10 * np.abs(G).max())


@pytest.mark.parametrize("polygon, spacing", [([[0, 0], [2, 0], [2, 0.2], [0, 0.2]], 0.02), (SLOPE_POLYGON, 0.5)])
def test_smoothing_cell_areas_sum_to_meshed_area(polygon, spacing):
    xy = particles_in_polygon(polygon, spacing, jitter=0.15, seed=1)
    mesh = triangulate(xy, spacing)
    _, node_area = smoothed_gradient(xy, np.zeros_like(xy), mesh.elem_nodes)
    p0, p1, p2 = (xy[mesh.elem_nodes[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    elem_area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert node_area.sum() == pytest.approx(elem_area.sum(), rel=1e-12)
    assert node_area.sum() == pytest.approx(_polygon_area(polygon), rel=1e-9)


def test_uniform_stress_gives_boundary_traction_only():
    """A constant stress field is self-equilibrated: zero force on interior particles, and the
    forces on the boundary particles integrate the traction sigma n over each side."""
    width, height, h = 3.0, 2.0, 0.25
    xy = particles_in_polygon([[0, 0], [width, 0], [width, height], [0, height]], h, jitter=0.2, seed=7)
    mesh = triangulate(xy, h)
    stress = np.tile([-100.0, -40.0, -20.0, 15.0], (len(xy), 1))
    force = np.zeros_like(xy)
    n = len(xy)
    power = assemble_nodal_force(xy, np.zeros((n, 2)), np.zeros((n, 4)), np.ones(n), stress, np.zeros(n, dtype=np.int64),
                                 np.ones(1), mesh.elem_nodes, mesh.elem_block_ptr, mesh.elem_colour_ptr,
                                 mesh.elem_colour_block, mesh.edge_nodes, mesh.edge_block_ptr, mesh.edge_colour_ptr,
                                 mesh.edge_colour_block, 0.0, 1e-3, 0.0, force, None)
    assert power == 0.0  # beta = 0: the internal force alone
    tol = 1e-9
    interior = (xy[:, 0] > tol) & (xy[:, 0] < width - tol) & (xy[:, 1] > tol) & (xy[:, 1] < height - tol)
    np.testing.assert_allclose(force[interior], 0.0, atol=1e-9 * 100 * h)
    right = xy[:, 0] > width - tol
    # node_force = -f_int; equilibrium needs the traction sigma n on the side x = width (n = +x):
    # f_int summed over that side = (s_xx, s_xy) * height
    np.testing.assert_allclose(-force[right].sum(axis=0), np.array([-100.0, 15.0]) * height, rtol=1e-9)
    np.testing.assert_allclose(force.sum(axis=0), 0.0, atol=1e-9 * 100 * width)
