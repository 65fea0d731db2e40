"""Single kernels of the core called on a cloud of one's own, and plain reference definitions
they are checked against (patch tests, the mesh-quality check)."""

from __future__ import annotations

import numpy as np

from spfem_core.jit import kernel
from spfem_core.mesh import mesh_from_elements
from spfem_core.smoothing import smooth_velocity_gradient


def smoothed_gradient(node_xy_m: np.ndarray, node_values: np.ndarray, elem_nodes: np.ndarray):
    """The time loop's smoothed gradient of a nodal vector field (n, 2) on the triangles
    ``elem_nodes``: (L (n, 4) as xx, xy, yx, yy; cell areas A_k (n,))."""
    n = node_xy_m.shape[0]
    mesh = mesh_from_elements(elem_nodes, n)
    node_L = np.zeros((n, 4))
    node_area = np.zeros(n)
    smooth_velocity_gradient(np.ascontiguousarray(node_xy_m, dtype=np.float64),
                             np.ascontiguousarray(node_values, dtype=np.float64), mesh.elem_nodes,
                             mesh.elem_block_ptr, mesh.elem_colour_ptr, mesh.elem_colour_block, node_L,
                             node_area, None)
    return node_L, node_area


@kernel
def all_corners_min_angle(node_xy, elem_nodes):
    """The plain definition of the mesh quality: atan2(|u x v|, u . v) at every corner of every
    triangle, the minimum (``mesh.element_quality_min_angle`` must equal it to the bit)."""
    theta_min = np.pi
    for e in range(elem_nodes.shape[0]):
        for corner in range(3):
            i = elem_nodes[e, corner]
            j = elem_nodes[e, (corner + 1) % 3]
            k = elem_nodes[e, (corner + 2) % 3]
            ux = node_xy[j, 0] - node_xy[i, 0]
            uy = node_xy[j, 1] - node_xy[i, 1]
            vx = node_xy[k, 0] - node_xy[i, 0]
            vy = node_xy[k, 1] - node_xy[i, 1]
            theta = np.arctan2(abs(ux * vy - uy * vx), ux * vx + uy * vy)
            if theta < theta_min:
                theta_min = theta
    return theta_min
