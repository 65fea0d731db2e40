"""Node-based strain smoothing (NS-FEM) on linear triangles, in the element-wise form.

Node k's smoothing cell is one third of every triangle attached to it:

    A_k = sum_{e ∋ k} A_e / 3
    L_k = (1 / A_k) sum_{e ∋ k} (A_e / 3) L_e,      L_e = sum_{I ∈ e} v_I ⊗ grad N_I^e

which equals grad N_I(x_k) = (1/A_k) sum_e (A_e/3) grad N_I^e applied to the nodal velocities,
without forming per-node gradient lists.  The internal force is the matching transpose:

    f_I = sum_k A_k B_I(x_k)^T sigma_k = sum_{e ∋ I} A_e B_I^e^T sigma_bar_e,
    sigma_bar_e = (sigma_i + sigma_j + sigma_k) / 3.

Both run as two parallel loops (``jit`` module doc): one over elements, writing each
element's own terms, then one over nodes, each summing its elements' terms in ascending
element order (``Mesh.node_elem_*``).

Velocity gradients are stored as (xx, xy, yx, yy) with L_ab = d v_a / d x_b.
"""

from __future__ import annotations

from numba import prange

from spfem_core.jit import parallel_kernel


@parallel_kernel
def smooth_velocity_gradient(node_xy, node_v, elem_nodes, node_elem_ptr, node_elem_idx, elem_geom, elem_weighted,
                             node_L, node_area):
    """Element geometry and the smoothed velocity gradient of every node.

    Fills ``elem_geom`` (n_elem, ``state.ELEM_GEOM_WIDTH``) with b_I = dN/dx, c_I = dN/dy and
    A_e from the current coordinates, ``elem_weighted`` (n_elem, 5) with A_e / 3 and
    (A_e / 3) L_e, ``node_area`` with A_k and ``node_L`` with L_k (zero for a particle in no
    triangle).
    Returns (number of elements with signed area <= 0, max over elements of |sym L_e|^2);
    the second bounds how fast any element angle can change: |d theta/dt| <= 2 |sym L_e|.
    """
    n_inverted = 0
    max_rate_sq = 0.0
    for e in prange(elem_nodes.shape[0]):
        i = elem_nodes[e, 0]
        j = elem_nodes[e, 1]
        k = elem_nodes[e, 2]
        xi, yi = node_xy[i, 0], node_xy[i, 1]
        xj, yj = node_xy[j, 0], node_xy[j, 1]
        xk, yk = node_xy[k, 0], node_xy[k, 1]
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
        elem_geom[e, 0] = bi
        elem_geom[e, 1] = bj
        elem_geom[e, 2] = bk
        elem_geom[e, 3] = ci
        elem_geom[e, 4] = cj
        elem_geom[e, 5] = ck
        elem_geom[e, 6] = area
        vxi, vyi = node_v[i, 0], node_v[i, 1]
        vxj, vyj = node_v[j, 0], node_v[j, 1]
        vxk, vyk = node_v[k, 0], node_v[k, 1]
        lxx = vxi * bi + vxj * bj + vxk * bk
        lxy = vxi * ci + vxj * cj + vxk * ck
        lyx = vyi * bi + vyj * bj + vyk * bk
        lyy = vyi * ci + vyj * cj + vyk * ck
        w = area / 3.0
        elem_weighted[e, 0] = w
        elem_weighted[e, 1] = w * lxx
        elem_weighted[e, 2] = w * lxy
        elem_weighted[e, 3] = w * lyx
        elem_weighted[e, 4] = w * lyy
        dxy = 0.5 * (lxy + lyx)
        max_rate_sq = max(max_rate_sq, lxx * lxx + lyy * lyy + 2.0 * dxy * dxy)
    for n in prange(node_xy.shape[0]):
        a = 0.0
        l0 = 0.0
        l1 = 0.0
        l2 = 0.0
        l3 = 0.0
        for p in range(node_elem_ptr[n], node_elem_ptr[n + 1]):
            e = node_elem_idx[p]
            a += elem_weighted[e, 0]
            l0 += elem_weighted[e, 1]
            l1 += elem_weighted[e, 2]
            l2 += elem_weighted[e, 3]
            l3 += elem_weighted[e, 4]
        node_area[n] = a
        if a > 0.0:
            inv_a = 1.0 / a
            l0 *= inv_a
            l1 *= inv_a
            l2 *= inv_a
            l3 *= inv_a
        node_L[n, 0] = l0
        node_L[n, 1] = l1
        node_L[n, 2] = l2
        node_L[n, 3] = l3
    return n_inverted, max_rate_sq


@parallel_kernel
def add_internal_force(elem_nodes, node_elem_ptr, elem_entry, elem_geom, corner_force, node_stress, node_force):
    """node_force[I] = -sum_{e ∋ I} A_e B_I^e^T sigma_bar_e (sigma_bar_e: vertex mean), overwriting
    ``node_force``; ``corner_force`` (3 n_elem, 2) keeps each term at its corner's entry of the
    node->element lists (``Mesh.elem_entry``), so that each node sums a contiguous range.

    With B_I^T sigma = (b_I s_xx + c_I s_xy, b_I s_xy + c_I s_yy).
    """
    third = 1.0 / 3.0
    for e in prange(elem_nodes.shape[0]):
        i = elem_nodes[e, 0]
        j = elem_nodes[e, 1]
        k = elem_nodes[e, 2]
        sxx = (node_stress[i, 0] + node_stress[j, 0] + node_stress[k, 0]) * third
        syy = (node_stress[i, 1] + node_stress[j, 1] + node_stress[k, 1]) * third
        sxy = (node_stress[i, 3] + node_stress[j, 3] + node_stress[k, 3]) * third
        area = elem_geom[e, 6]
        for corner in range(3):
            b = elem_geom[e, corner] * area
            c = elem_geom[e, 3 + corner] * area
            entry = elem_entry[e, corner]
            corner_force[entry, 0] = b * sxx + c * sxy
            corner_force[entry, 1] = b * sxy + c * syy
    for n in prange(node_force.shape[0]):
        fx = 0.0
        fy = 0.0
        for p in range(node_elem_ptr[n], node_elem_ptr[n + 1]):
            fx -= corner_force[p, 0]
            fy -= corner_force[p, 1]
        node_force[n, 0] = fx
        node_force[n, 1] = fy
