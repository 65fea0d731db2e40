"""When and how the mesh is rebuilt during a stage, and what a rebuild does to the particles.

- **Quality threshold.**  The loop rebuilds when the smallest element angle falls below a
  threshold.  After a rebuild whose smallest angle is theta the threshold becomes
  min(settings.min_angle_deg, max(theta - 5 deg, theta / 2)).  ESPFEM2D clamps at 5 deg
  instead of theta / 2; a fresh Delaunay mesh of a disordered cloud is often only 8-10 deg at
  its worst element, which left a 3-5 deg budget and a rebuild every few dozen steps.  Between
  exact checks the loop spends a budget of theta - threshold - margin with a cheap bound on
  the angle change (``stepper`` module doc).
- **Crowded particles** (:func:`smooth_crowded_particles`) are spread on the outgoing mesh,
  then the cloud is triangulated once (``mesh.triangulate``).
- **Detached particles** (in no triangle: thrown off a flow) rejoin the mesh at a rebuild once
  one of them has come within h of a meshed particle (:meth:`Remesher.orphans_can_rejoin`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.mesh import Mesh, element_quality_min_angle, triangulate
from spfem_core.state import NodeState
from spfem_core.stepper import LOOP_ANGLE_BUDGET, LOOP_ANGLE_USED

ANGLE_MARGIN_RAD = math.radians(1.0)
"""Safety margin on the cheap angle bound (it uses the strain rate of the previous step)."""

ANGLE_THRESHOLD_DROP_RAD = math.radians(5.0)
"""The adaptive threshold lies this far below the smallest angle of a fresh mesh (module doc)."""


def _neighbour_sums(node_xy: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per node, the sum of the positions of its neighbours along ``edges`` (m, 2) and their number
    (each edge (i, j) given once)."""
    sums = np.zeros_like(node_xy)
    degree = np.zeros(node_xy.shape[0])
    for a, b in ((0, 1), (1, 0)):
        np.add.at(sums, edges[:, a], node_xy[edges[:, b]])
        np.add.at(degree, edges[:, a], 1.0)
    return sums, degree


def smooth_crowded_particles(nodes: NodeState, mesh: Mesh, min_distance_m: float) -> int:
    """One Laplacian pass over the free particles whose nearest mesh neighbour is closer than
    ``min_distance_m``: an interior particle moves to the mean of its mesh neighbours, a
    boundary particle (on an edge of one triangle) to the mean of its neighbours along the
    boundary, so that it slides along the free surface or a floor instead of leaving it.
    The displacement moves with the position (u += delta x), so u stays x - x0.  Returns the
    number of particles moved.

    Boundary particles used to be left alone.  On the granular collapse at h = 1 mm the
    particles at the flow front, pressed onto the floor, closed up pairwise (with the element
    time-step rule of the time, the triangles between them cut the step 500-fold; the bound
    of ``spfem_core.timestep`` is not fooled by such pairs, but crowded particles still make
    poor smoothing cells).
    """
    xy = nodes.xy_m
    n = xy.shape[0]
    edges = mesh.edge_nodes
    if edges.shape[0] == 0:
        return 0
    length = np.hypot(*(xy[edges[:, 1]] - xy[edges[:, 0]]).T)
    nearest = np.full(n, np.inf)
    np.minimum.at(nearest, edges[:, 0], length)
    np.minimum.at(nearest, edges[:, 1], length)
    crowded = nearest < min_distance_m
    movable = crowded & ~nodes.fixed.any(axis=1)
    if not movable.any():
        return 0
    # boundary edges: sides of a single triangle
    tri = mesh.elem_nodes
    side = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    unique, count = np.unique(side[:, 0] * n + side[:, 1], return_counts=True)
    boundary_edges = np.stack([unique[count == 1] // n, unique[count == 1] % n], axis=1)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[boundary_edges.ravel()] = True
    # interior particles average over all their mesh neighbours, boundary ones over their
    # neighbours along the boundary
    sums, degree = _neighbour_sums(xy, edges)
    boundary_sums, boundary_degree = _neighbour_sums(xy, boundary_edges)
    sums[on_boundary] = boundary_sums[on_boundary]
    degree[on_boundary] = boundary_degree[on_boundary]
    moved = np.flatnonzero(movable & (degree > 0))
    if moved.size == 0:
        return 0
    target = sums[moved] / degree[moved, None]
    delta = target - xy[moved]
    xy[moved] = target
    nodes.displacement_m[moved] += delta
    return int(moved.size)


class Remesher:
    """The mesh-quality threshold, rebuilds and the rejoin test of one simulation (module doc)."""

    def __init__(self, spacing_m, alpha: float, min_angle_deg: float, crowded_fraction: float):
        """``spacing_m``: h, or one per particle (a graded cloud: the alpha shape follows it, the
        crowding and rejoin distances take the finest)."""
        self.node_spacing_m = spacing_m
        self.spacing_m = float(np.min(spacing_m))
        self.alpha = float(alpha)
        self.ceiling_rad = math.radians(min_angle_deg)
        self.crowded_fraction = float(crowded_fraction)
        self.threshold_rad = self.ceiling_rad  # rebuild below this smallest angle
        self._rejoin_tried_xy = None  # detached positions at the last rejoin rebuild that took none in

    def triangulate(self, node_xy_m: np.ndarray) -> Mesh:
        """The alpha-shape mesh of the particles as they are."""
        return triangulate(node_xy_m, self.node_spacing_m, self.alpha)

    def rebuild(self, nodes: NodeState, outgoing: Mesh) -> tuple[Mesh, int]:
        """Spread crowded particles, then triangulate once; (new mesh, particles moved).

        The crowded particles are found on the outgoing mesh (it still joins every particle
        to its near neighbours; it has only lost quality).  Smoothing after the new Delaunay
        meant a second one whenever a particle moved, a third of all rebuilds of the granular
        collapse, and Qhull is three quarters of a rebuild's cost.
        """
        moved = smooth_crowded_particles(nodes, outgoing, self.crowded_fraction * self.spacing_m)
        return self.triangulate(nodes.xy_m), moved

    def reset_angle_budget(self, node_xy_m: np.ndarray, mesh: Mesh, loop: np.ndarray, after_rebuild: bool) -> None:
        """Measure the smallest angle now and give the loop the budget it may spend before the
        cheap bound could reach the threshold; after a rebuild the threshold adapts (module doc)."""
        min_angle = float(element_quality_min_angle(node_xy_m, mesh.elem_nodes))
        if after_rebuild:
            self.threshold_rad = min(max(min_angle - ANGLE_THRESHOLD_DROP_RAD, 0.5 * min_angle), self.ceiling_rad)
        loop[LOOP_ANGLE_USED] = 0.0
        loop[LOOP_ANGLE_BUDGET] = max(min_angle - self.threshold_rad - ANGLE_MARGIN_RAD, 0.0)

    def orphans_can_rejoin(self, node_xy_m: np.ndarray, mesh: Mesh) -> bool:
        """True when a particle outside the mesh has come within h of a meshed particle (closer
        than that the alpha shape takes it in; further, a rebuild would leave it out again)."""
        orphans = mesh.orphan_nodes
        if orphans.size == 0:
            return False
        tried = self._rejoin_tried_xy
        if tried is not None and tried.shape == (orphans.size, 2):
            # the last rebuild left them out: try again only once one has moved h/2
            moved = np.hypot(*(node_xy_m[orphans] - tried).T).max()
            if moved < 0.5 * self.spacing_m:
                return False
        self._rejoin_tried_xy = node_xy_m[orphans].copy()

        meshed = np.ones(node_xy_m.shape[0], dtype=bool)
        meshed[orphans] = False
        tree = cKDTree(node_xy_m[meshed])
        distance, _ = tree.query(node_xy_m[orphans], k=1)
        return bool(np.any(distance < self.spacing_m))
