"""The upper surface of the particle cloud, where surface loads act.

The upper surface is the boundary edges of the first mesh whose outward normal points up: going
a -> b with the material on the left, x_b < x_a.  A load puts its force on the particles of these
edges, split by their linear shape functions N_a = (x - x_b) / (x_a - x_b), N_b = 1 - N_a (exact
resultant and moment).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spfem_core.mesh import boundary_edges, triangulate


@dataclass(frozen=True)
class UpperSurface:
    """The upward-facing boundary edges (a, b) of the first mesh, with x_b < x_a."""

    edges: np.ndarray  # (n_edges, 2) int64 particles a, b
    x_a_m: np.ndarray  # (n_edges,) x of a
    x_b_m: np.ndarray  # (n_edges,) x of b (< x_a)

    @classmethod
    def of_cloud(cls, node_xy_m: np.ndarray, spacing_m, alpha: float) -> UpperSurface:
        """The upper surface of the first mesh of the particles ``node_xy_m`` (spacing: h, or one per particle)."""
        edges = boundary_edges(triangulate(node_xy_m, spacing_m, alpha).elem_nodes)
        edges = edges[node_xy_m[edges[:, 1], 0] < node_xy_m[edges[:, 0], 0]]
        return cls(edges, node_xy_m[edges[:, 0], 0], node_xy_m[edges[:, 1], 0])
