"""Node-based strain smoothing (NS-FEM) on linear triangles, in the element-wise form.

Node k's smoothing cell is one third of every triangle attached to it:

    A_k = sum_{e ∋ k} A_e / 3
    L_k = (1 / A_k) sum_{e ∋ k} (A_e / 3) L_e,      L_e = sum_{I ∈ e} v_I ⊗ grad N_I^e

which equals grad N_I(x_k) = (1/A_k) sum_e (A_e/3) grad N_I^e applied to the nodal velocities,
without forming per-node gradient lists (its transpose, the internal force, is in
``nodal_force``).  The elements add into their nodes in coloured blocks (``jit`` module doc):
one colour after another, the blocks of a colour at once.

Velocity gradients are stored as (xx, xy, yx, yy) with L_ab = d v_a / d x_b.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from spfem_core.jit import FOUR, ONE, TWO, fill_zero, inline_kernel, inner_kernel, kernel, parallel_inner_kernel
from spfem_core.state import L_XX, L_XY, L_YX, L_YY

FLAT_L_XX, FLAT_L_XY, FLAT_L_YX, FLAT_L_YY = (np.uint64(c) for c in (L_XX, L_XY, L_YX, L_YY))
"""The gradient's columns as unsigned offsets into a flat row (``jit`` module doc)."""


@inline_kernel
def scaled_gradients(node_xy, i, j, k):
    """(A b_i, A b_j, A b_k, A c_i, A c_j, A c_k) of the triangle i, j, k (counter-clockwise): the
    shape-function gradients times its area, A b_I = (y_J - y_K) / 2 and A c_I = (x_K - x_J) / 2
    for I, J, K in cyclic order; no division, so an inverted triangle gives finite values."""
    xi, yi = node_xy[i, 0], node_xy[i, 1]
    xj, yj = node_xy[j, 0], node_xy[j, 1]
    xk, yk = node_xy[k, 0], node_xy[k, 1]
    return (0.5 * (yj - yk), 0.5 * (yk - yi), 0.5 * (yi - yj), 0.5 * (xk - xj), 0.5 * (xi - xk), 0.5 * (xj - xi))


@kernel
def smooth_velocity_gradient(node_xy, node_v, elem_nodes, elem_block_ptr, elem_colour_ptr, elem_colour_block,
                             node_L, node_area, n_threads):
    """The smoothed velocity gradient of every node.

    Fills ``node_area`` with A_k and ``node_L`` with L_k (zero for a particle in no triangle), from
    the current coordinates.  The element geometry is not stored: the internal force and the
    water forces form A_e b_I and A_e c_I again from the coordinates (:func:`scaled_gradients`),
    cheaper than writing and reading 56 bytes per element per step once the cloud outgrows the
    core's cache.  The elements run in coloured blocks (``mesh.coloured_blocks``), on
    threads unless ``n_threads`` is None (``jit.kernel_threads``), else in a plain loop.
    Returns (number of elements with signed area <= 0, max over elements of |sym L_e|^2);
    the second bounds how fast any element angle can change: |d theta/dt| <= 2 |sym L_e|.
    """
    n_block = elem_block_ptr.shape[0] - 1
    fill_zero(node_area)
    fill_zero(node_L)
    block_inverted = np.zeros(n_block, dtype=np.int64)
    block_rate_sq = np.zeros(n_block)
    if n_threads is not None:  # decided when compiling (jit.kernel_threads)
        smooth_blocks_threaded(node_xy, node_v, elem_nodes, elem_block_ptr, elem_colour_ptr, elem_colour_block,
                               node_L, node_area, block_inverted, block_rate_sq)
    else:  # the same blocks in the same order
        for slot in range(n_block):
            block = elem_colour_block[slot]
            block_inverted[block], block_rate_sq[block] = smooth_elements(
                node_xy, node_v, elem_nodes, elem_block_ptr[block], elem_block_ptr[block + 1], node_L, node_area)
    for n in range(node_xy.shape[0]):
        a = node_area[n]
        if a > 0.0:
            inv_a = 1.0 / a
            for c in range(4):
                node_L[n, c] *= inv_a
    n_inverted = 0
    max_rate_sq = 0.0
    for block in range(n_block):  # plain loops: numpy's sum and max cost 0.5 s of a cold compile
        n_inverted += block_inverted[block]
        if block_rate_sq[block] > max_rate_sq:
            max_rate_sq = block_rate_sq[block]
    return n_inverted, max_rate_sq


@parallel_inner_kernel
def smooth_blocks_threaded(node_xy, node_v, elem_nodes, elem_block_ptr, elem_colour_ptr, elem_colour_block,
                           node_L, node_area, block_inverted, block_rate_sq):
    """:func:`smooth_elements` of every block, colour after colour, the blocks of a colour on
    threads (kept apart: a function with a parallel loop costs about 3 us a call even when it
    runs no thread)."""
    for colour in range(elem_colour_ptr.shape[0] - 1):  # blocks of one colour share no node
        for slot in prange(elem_colour_ptr[colour], elem_colour_ptr[colour + 1]):
            block = elem_colour_block[slot]
            block_inverted[block], block_rate_sq[block] = smooth_elements(
                node_xy, node_v, elem_nodes, elem_block_ptr[block], elem_block_ptr[block + 1], node_L, node_area)


@inner_kernel
def smooth_elements(node_xy, node_v, elem_nodes, start, end, node_L, node_area):
    """The terms (A_e/3, (A_e/3) L_e) of elements start..end-1 added into their nodes; (elements
    with signed area <= 0, max |sym L_e|^2) of these elements."""
    n_inverted = 0
    max_rate_sq = 0.0
    xy, velocity, gradient = node_xy.reshape(-1), node_v.reshape(-1), node_L.reshape(-1)  # flat rows (jit doc)
    for e in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        i = np.uint64(elem_nodes[e, 0])
        j = np.uint64(elem_nodes[e, 1])
        k = np.uint64(elem_nodes[e, 2])
        i2, j2, k2 = i * TWO, j * TWO, k * TWO  # the rows of i, j, k in the (n, 2) arrays
        xi, yi = xy[i2], xy[i2 + ONE]
        xj, yj = xy[j2], xy[j2 + ONE]
        xk, yk = xy[k2], xy[k2 + ONE]
        two_area = (xj - xi) * (yk - yi) - (xk - xi) * (yj - yi)
        if two_area <= 0.0:
            n_inverted += 1
            two_area = 1e-300  # keep going: the caller rebuilds the mesh before using this step
        inv = 1.0 / two_area
        bi = (yj - yk) * inv
        bj = (yk - yi) * inv
        bk = (yi - yj) * inv
        ci = (xk - xj) * inv
        cj = (xi - xk) * inv
        ck = (xj - xi) * inv
        area = 0.5 * two_area
        vxi, vyi = velocity[i2], velocity[i2 + ONE]
        vxj, vyj = velocity[j2], velocity[j2 + ONE]
        vxk, vyk = velocity[k2], velocity[k2 + ONE]
        lxx = vxi * bi + vxj * bj + vxk * bk
        lxy = vxi * ci + vxj * cj + vxk * ck
        lyx = vyi * bi + vyj * bj + vyk * bk
        lyy = vyi * ci + vyj * cj + vyk * ck
        dxy = 0.5 * (lxy + lyx)
        rate_sq = lxx * lxx + lyy * lyy + 2.0 * dxy * dxy
        if rate_sq > max_rate_sq:
            max_rate_sq = rate_sq
        w = area / 3.0
        for n in (i, j, k):
            row = n * FOUR  # the row of n in the (n, 4) gradients
            node_area[n] += w
            gradient[row + FLAT_L_XX] += w * lxx
            gradient[row + FLAT_L_XY] += w * lxy
            gradient[row + FLAT_L_YX] += w * lyx
            gradient[row + FLAT_L_YY] += w * lyy
    return n_inverted, max_rate_sq
