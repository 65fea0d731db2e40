"""The triangle mesh of a particle cloud: Delaunay, alpha-shape filter, CSR adjacency.

Particles are the mesh nodes.  ``triangulate`` builds the Delaunay triangulation of all
particles (scipy / Qhull), drops triangles whose circumradius R = abc/(4A) exceeds alpha h
(the alpha shape, which recovers concave boundaries and separates detached pieces), orients
every triangle counter-clockwise and builds node->element and node->node adjacency as CSR
pairs (``*_ptr``, ``*_idx``), with no fixed-width tables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.spatial import Delaunay

from spfem_core.jit import PARTICLES_PER_THREAD, inner_kernel, kernel
from spfem_core.state import MeshArrays

QHULL_OPTIONS = "Qbb Qc Qz Q12"
"""scipy's 2D default.  No 'QJ': joggling perturbs the input and can drop particles that
lie on straight boundary edges.  Qhull keeps such collinear hull points as vertices here
(the lifted points lie on a parabola, strictly convex), so lattice clouds have no orphans."""

DEGENERATE_AREA_FACTOR = 1e-12
"""Triangles with area <= this factor times h^2 are degenerate and dropped."""


@dataclass(frozen=True, eq=False)
class Mesh:
    """Linear triangles over the particles, with CSR adjacency.

    ``elem_nodes[e]`` are the three nodes of element e, counter-clockwise.  The elements
    attached to node k are ``node_elem_idx[node_elem_ptr[k]:node_elem_ptr[k + 1]]``
    (ascending); its neighbours along mesh edges are
    ``node_node_idx[node_node_ptr[k]:node_node_ptr[k + 1]]`` (ascending, k excluded).
    Elements are numbered in the order of their lowest node and edges in the order of their
    first; both are cut into blocks coloured so that blocks of one colour share no node
    (:func:`coloured_blocks`): the kernels run one colour after another, its blocks at once,
    each adding into its nodes with no other thread writing there.  All arrays are int64 and
    C-contiguous.
    """

    elem_nodes: np.ndarray  # (n_elem, 3) int64, counter-clockwise
    node_elem_ptr: np.ndarray  # (n_nodes + 1,) int64
    node_elem_idx: np.ndarray  # (3 n_elem,) int64
    node_node_ptr: np.ndarray  # (n_nodes + 1,) int64
    node_node_idx: np.ndarray  # (2 n_edges,) int64
    n_nodes: int
    edge_nodes: np.ndarray  # (n_edges, 2) int64, each mesh edge once as (i, j) with i < j
    elem_block_ptr: np.ndarray  # (n_blocks + 1,) int64: elements of block b are elem_block_ptr[b]:elem_block_ptr[b + 1]
    elem_colour_ptr: np.ndarray  # (n_colours + 1,) int64: blocks of colour c are elem_colour_block[ptr[c]:ptr[c + 1]]
    elem_colour_block: np.ndarray  # (n_blocks,) int64: no two blocks of one colour share a node
    edge_block_ptr: np.ndarray  # the same three for the edges
    edge_colour_ptr: np.ndarray
    edge_colour_block: np.ndarray

    @property
    def arrays(self) -> MeshArrays:
        """The arrays the kernels take."""
        return MeshArrays(self.elem_nodes, self.node_elem_ptr, self.node_elem_idx, self.edge_nodes,
                          self.node_node_ptr, self.node_node_idx, self.elem_block_ptr, self.elem_colour_ptr,
                          self.elem_colour_block, self.edge_block_ptr, self.edge_colour_ptr, self.edge_colour_block)

    @property
    def n_elem(self) -> int:
        """Number of triangles."""
        return int(self.elem_nodes.shape[0])

    @property
    def orphan_nodes(self) -> np.ndarray:
        """Indices (int64) of particles that belong to no triangle."""
        return np.flatnonzero(np.diff(self.node_elem_ptr) == 0).astype(np.int64)


def triangulate(node_xy_m, spacing_m, alpha: float = 1.5) -> Mesh:
    """Alpha-shape triangulation of the particles ``node_xy_m`` (n, 2) with spacing h: a number,
    or one per particle (a graded cloud), where a triangle's h is the largest of its vertices'.

    Keeps a Delaunay triangle when its area A > 1e-12 h^2 and its circumradius
    R = abc / (4A) <= alpha h (a, b, c the side lengths); reorders the vertices of every
    triangle with signed area < 0 so that all are counter-clockwise.
    """
    node_xy_m = np.ascontiguousarray(node_xy_m, dtype=np.float64)
    if node_xy_m.ndim != 2 or node_xy_m.shape[1] != 2:
        raise ValueError(f"node_xy_m: expected shape (n, 2), got {node_xy_m.shape}")
    if node_xy_m.shape[0] < 3:
        raise ValueError(f"node_xy_m: need at least 3 particles, got {node_xy_m.shape[0]}")
    if not np.all(np.isfinite(node_xy_m)):
        raise ValueError("node_xy_m: positions must be finite")
    per_node = np.ndim(spacing_m) == 1
    h = np.asarray(spacing_m, dtype=np.float64)
    if per_node and h.shape != (node_xy_m.shape[0],):
        raise ValueError(f"spacing_m: expected a number or {node_xy_m.shape[0]} values, got {h.shape}")
    if not (np.all(np.isfinite(h)) and np.all(h > 0.0)):
        raise ValueError(f"spacing_m: must be finite and > 0, got {spacing_m}")
    if not (np.isfinite(alpha) and alpha > 0.0):
        raise ValueError(f"alpha: must be finite and > 0, got {alpha}")

    elem_nodes = delaunay_triangles(node_xy_m)
    area_m2, circumradius_m = _signed_area_and_circumradius(node_xy_m, elem_nodes)
    if per_node:
        h = h[elem_nodes].max(axis=1)
    keep = (np.abs(area_m2) > DEGENERATE_AREA_FACTOR * h * h) & (circumradius_m <= alpha * h)
    elem_nodes = elem_nodes[keep]
    clockwise = area_m2[keep] < 0.0
    elem_nodes[clockwise] = elem_nodes[clockwise][:, [0, 2, 1]]
    return mesh_from_elements(np.ascontiguousarray(elem_nodes), node_xy_m.shape[0])


def boundary_edges(elem_nodes: np.ndarray) -> np.ndarray:
    """Sides of exactly one triangle (the alpha shape's boundary, holes and cracks included), as
    (a, b) int64 in that counter-clockwise triangle's order: the material lies on the left of a -> b."""
    elem_nodes = np.asarray(elem_nodes, dtype=np.int64).reshape(-1, 3)
    sides = np.concatenate([elem_nodes[:, [0, 1]], elem_nodes[:, [1, 2]], elem_nodes[:, [2, 0]]])
    n = int(sides.max()) + 1 if sides.size else 1
    keys = np.minimum(sides[:, 0], sides[:, 1]) * n + np.maximum(sides[:, 0], sides[:, 1])
    _, first, count = np.unique(keys, return_index=True, return_counts=True)
    return np.ascontiguousarray(sides[np.sort(first[count == 1])])


def delaunay_triangles(node_xy_m: np.ndarray) -> np.ndarray:
    """All Delaunay triangles (n_tri, 3) int64 of the points, any orientation, unfiltered.

    Qhull sees the points from :func:`local_origin`: its precision tests scale with the largest
    coordinate, and a section drawn in survey coordinates (x ~ 1e7 m at h = 1 m) otherwise loses
    a third of its triangles."""
    origin = local_origin(node_xy_m)
    local = node_xy_m - origin if np.any(origin) else node_xy_m
    triangulation = Delaunay(local, qhull_options=QHULL_OPTIONS)
    return triangulation.simplices.astype(np.int64)


def local_origin(node_xy_m: np.ndarray) -> np.ndarray:
    """(2,) an origin near the points from which their coordinates are exact: per axis, the
    integer part of the coordinate nearest zero when all have one sign, else 0.

    x - o is exact: o is an integer of the same sign as x with |o| <= |x|, so x - o is a multiple
    of the spacing of floats at x (at most 1 below 2^52) and no larger than x.  Points around
    the origin keep o = 0, and with it their triangulation to the bit."""
    low, high = node_xy_m.min(axis=0), node_xy_m.max(axis=0)
    return np.where(low > 0.0, np.trunc(low), np.where(high < 0.0, np.trunc(high), 0.0))


def mesh_from_elements(elem_nodes: np.ndarray, n_nodes: int) -> Mesh:
    """Build the CSR node->element and node->node adjacency of given triangles.

    Both are sparse-matrix patterns, built by scipy's compressed-row conversion (a counting
    sort, O(n)): node->element from the 3 n_elem pairs (node, element), node->node from the
    directed edges (i, j) and (j, i) of every triangle side, duplicates summed away; column
    indices ascending within a row.  ``edge_nodes`` lists every (i, j) with j > i in row
    order; the blocks come from :func:`coloured_blocks`.  (``np.unique`` over edge keys was a quarter of a rebuild; a compiled kernel was
    2 ms faster at 20k particles but cost 0.6 s of compilation in every fresh process.)
    """
    elem_nodes = np.ascontiguousarray(elem_nodes, dtype=np.int64).reshape(-1, 3)
    # number the elements in the order of their lowest node: blocks of them are then compact in space
    # (few colours), and the elements of a node lie close together in memory (Qhull's order is scattered)
    elem_nodes = np.ascontiguousarray(elem_nodes[np.argsort(elem_nodes.min(axis=1), kind="stable")])
    n_elem = elem_nodes.shape[0]
    n_nodes = int(n_nodes)
    node_elem = _pattern(elem_nodes.ravel(), np.repeat(np.arange(n_elem, dtype=np.int64), 3), n_nodes, n_elem)
    first = elem_nodes.ravel()
    second = elem_nodes[:, [1, 2, 0]].ravel()
    node_node = _pattern(np.concatenate([first, second]), np.concatenate([second, first]), n_nodes, n_nodes)
    node_node_ptr, node_node_idx = node_node
    row = np.repeat(np.arange(n_nodes, dtype=np.int64), np.diff(node_node_ptr))
    upper = node_node_idx > row
    edge_nodes = np.ascontiguousarray(np.stack([row[upper], node_node_idx[upper]], axis=1))
    # a cloud too small for a second thread (jit.set_threads) takes one block: one pass per loop
    block_items = BLOCK_ITEMS if n_nodes >= 2 * PARTICLES_PER_THREAD else max(n_elem, edge_nodes.shape[0], 1)
    elem_blocks = coloured_blocks(elem_nodes, n_nodes, block_items)
    edge_blocks = coloured_blocks(edge_nodes, n_nodes, block_items)
    return Mesh(elem_nodes, *node_elem, *node_node, n_nodes, edge_nodes, *elem_blocks, *edge_blocks)


BLOCK_ITEMS = 512
"""Elements (or edges) per block of the parallel loops (``coloured_blocks``): 5,000 particles make
about 20 element blocks for 2 threads to share, and a block's bookkeeping is negligible."""


def coloured_blocks(item_nodes: np.ndarray, n_nodes: int, block_items: int = BLOCK_ITEMS
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(block_ptr, colour_ptr, colour_block) of the items ``item_nodes`` (elements or edges, (n, k)
    node numbers): contiguous blocks of ``block_items`` items, block b =
    ``block_ptr[b]:block_ptr[b + 1]``, coloured so that two blocks of one colour share no node;
    the blocks of colour c are ``colour_block[colour_ptr[c]:colour_ptr[c + 1]]``, ascending.

    Greedy colouring in block order (each block takes the lowest colour none of its neighbours
    has), from the mesh alone: never from the number of threads.  Items numbered in space
    order (the particles' Morton order, elements by their lowest node) give few colours."""
    n_items = item_nodes.shape[0]
    block_ptr = np.append(np.arange(0, n_items, block_items, dtype=np.int64), np.int64(n_items))
    if n_items == 0:
        return np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    n_block = block_ptr.size - 1
    block_of_item = np.repeat(np.arange(n_block, dtype=np.int64), np.diff(block_ptr))
    # the distinct (node, block) pairs, grouped by node: blocks that meet at a node conflict
    keys = np.unique(item_nodes.astype(np.int64) * n_block + block_of_item[:, None])
    node, block = keys // n_block, keys % n_block
    neighbours = [set() for _ in range(n_block)]
    for offset in range(1, n_block):
        same = node[offset:] == node[:-offset]
        if not same.any():
            break
        for a, b in zip(block[:-offset][same].tolist(), block[offset:][same].tolist()):
            neighbours[a].add(b)
            neighbours[b].add(a)
    colour = np.zeros(n_block, dtype=np.int64)
    for b in range(n_block):
        taken = {int(colour[other]) for other in neighbours[b] if other < b}
        colour[b] = next(c for c in range(len(taken) + 1) if c not in taken)
    colour_block = np.argsort(colour, kind="stable").astype(np.int64)
    colour_ptr = np.searchsorted(colour[colour_block], np.arange(colour.max() + 2)).astype(np.int64)
    return block_ptr, colour_ptr, colour_block


def _pattern(rows: np.ndarray, columns: np.ndarray, n_rows: int, n_columns: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR (ptr, idx) int64 of the set of (row, column) pairs, columns ascending in each row."""
    matrix = csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, columns)), shape=(n_rows, n_columns))
    matrix.sum_duplicates()  # also sorts the columns of every row
    return matrix.indptr.astype(np.int64), matrix.indices.astype(np.int64)


def _signed_area_and_circumradius(node_xy_m: np.ndarray, elem_nodes: np.ndarray):
    """A = ((x1 - x0)(y2 - y0) - (x2 - x0)(y1 - y0)) / 2 and R = abc / (4 |A|) per triangle."""
    p0, p1, p2 = (node_xy_m[elem_nodes[:, k]] for k in range(3))
    e01, e02, e12 = p1 - p0, p2 - p0, p2 - p1
    area_m2 = 0.5 * (e01[:, 0] * e02[:, 1] - e02[:, 0] * e01[:, 1])
    abc = np.hypot(*e01.T) * np.hypot(*e02.T) * np.hypot(*e12.T)
    with np.errstate(divide="ignore", invalid="ignore"):
        circumradius_m = abc / (4.0 * np.abs(area_m2))
    return area_m2, np.where(area_m2 != 0.0, circumradius_m, np.inf)


SINE_WINDOW = 1e-9
"""Elements whose smallest-angle sine is within this of the smallest are measured exactly."""


@kernel
def element_quality_min_angle(node_xy, elem_nodes):
    """Smallest interior angle (rad) over all triangles; pi for an empty mesh, NaN if any
    coordinate of a triangle is NaN (or infinite).

    The angle at vertex i between sides u and v is theta = atan2(|u x v|, u . v), the
    minimum over the corners of the candidates below.  atan2 was most of the cost (the check
    runs inside the time loop, up to every other step), so it is evaluated for a handful of
    elements: a triangle's smallest angle lies opposite its shortest side, with
    sin theta_min = |u x v| / (b c), b and c the two longer sides.  One pass keeps the
    smallest s^2 = |u x v|^2 / (b^2 c^2) seen so far (no root, no arctangent) and measures
    with atan2 every element whose s is within SINE_WINDOW of it.  Every element within the
    window of the final minimum is measured (the running minimum only falls), the window is
    far wider than rounding, and extra elements only add true angles: the result is the
    all-element atan2 minimum to the bit.
    """
    theta_min = np.pi
    window_sq = np.inf
    for e in range(elem_nodes.shape[0]):
        sine_sq = _smallest_angle_sine_sq(node_xy, elem_nodes, e)
        if sine_sq != sine_sq:
            return np.nan
        if sine_sq > window_sq:
            continue
        window = np.sqrt(sine_sq) + SINE_WINDOW
        if window * window < window_sq:
            window_sq = window * window
        for corner in range(3):
            i = elem_nodes[e, corner]
            j = elem_nodes[e, (corner + 1) % 3]
            k = elem_nodes[e, (corner + 2) % 3]
            ux = node_xy[j, 0] - node_xy[i, 0]
            uy = node_xy[j, 1] - node_xy[i, 1]
            vx = node_xy[k, 0] - node_xy[i, 0]
            vy = node_xy[k, 1] - node_xy[i, 1]
            theta = np.arctan2(abs(ux * vy - uy * vx), ux * vx + uy * vy)
            if theta != theta:
                return np.nan
            if theta < theta_min:
                theta_min = theta
    return theta_min


@inner_kernel
def _smallest_angle_sine_sq(node_xy, elem_nodes, e):
    """sin^2 of the smallest angle of triangle e: (2A)^2 / (b^2 c^2), b, c its two longest sides."""
    i = elem_nodes[e, 0]
    j = elem_nodes[e, 1]
    k = elem_nodes[e, 2]
    ux = node_xy[j, 0] - node_xy[i, 0]
    uy = node_xy[j, 1] - node_xy[i, 1]
    vx = node_xy[k, 0] - node_xy[i, 0]
    vy = node_xy[k, 1] - node_xy[i, 1]
    wx = vx - ux
    wy = vy - uy
    cross = ux * vy - uy * vx
    lu = ux * ux + uy * uy
    lv = vx * vx + vy * vy
    lw = wx * wx + wy * wy
    shortest = min(lu, min(lv, lw))
    if shortest == lu:
        longer = lv * lw
    elif shortest == lv:
        longer = lu * lw
    else:
        longer = lu * lv
    if longer == 0.0:  # all three vertices at one point: an angle of 0, as atan2(0, 0) says
        return 0.0
    return cross * cross / longer


@kernel
def count_inverted(node_xy, elem_nodes):
    """Number of triangles with signed area 2A = (x1 - x0)(y2 - y0) - (x2 - x0)(y1 - y0) <= 0
    (a NaN area counts as inverted)."""
    n_inverted = 0
    for e in range(elem_nodes.shape[0]):
        n0 = elem_nodes[e, 0]
        n1 = elem_nodes[e, 1]
        n2 = elem_nodes[e, 2]
        twice_area = (node_xy[n1, 0] - node_xy[n0, 0]) * (node_xy[n2, 1] - node_xy[n0, 1]) - (
            node_xy[n2, 0] - node_xy[n0, 0]
        ) * (node_xy[n1, 1] - node_xy[n0, 1])
        if not twice_area > 0.0:
            n_inverted += 1
    return n_inverted
