"""The nodal force of a step: internal force of the smoothed stress plus the stabilisation bonds.

    f_I = - sum_{e ∋ I} A_e B_I^e^T sigma_bar_e  +  sum_{bonds I-J} F_JI

with sigma_bar_e = (sigma_i + sigma_j + sigma_k) / 3 (the transpose of the strain smoothing,
``smoothing``) and B_I^T sigma = (b_I s_xx + c_I s_xy, b_I s_xy + c_I s_yy); F the bond forces
of ``stabilisation`` (only when beta > 0).

Elements, then bonds, add into their nodes in coloured blocks (``jit`` module doc,
``mesh.coloured_blocks``): one colour after another, the blocks of a colour at once; the
bonds' power is summed per block, then over the blocks in order.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from spfem_core.jit import FOUR, ONE, TWO, fill_zero, inner_kernel, kernel, parallel_inner_kernel
from spfem_core.stabilisation import bond_force
from spfem_core.state import XX, XY, YY

FLAT_XX, FLAT_YY, FLAT_XY = (np.uint64(c) for c in (XX, YY, XY))
"""The stress columns as unsigned offsets into a flat row (``jit`` module doc)."""


@kernel
def assemble_nodal_force(node_xy, node_v, node_L, node_area, node_stress, node_material_row, mat_youngs, elem_nodes,
                         elem_block_ptr, elem_colour_ptr, elem_colour_block, edge_nodes, edge_block_ptr,
                         edge_colour_ptr, edge_colour_block, beta, dt, min_bond_sq, node_force, n_threads):
    """Overwrite ``node_force`` with f_int + f_stab (module doc); return the bonds' power (W/m,
    0 when beta = 0).  On threads unless ``n_threads`` is None (``jit.kernel_threads``), else in plain
    loops (same order)."""
    fill_zero(node_force)
    if n_threads is not None:  # decided when compiling (jit.kernel_threads)
        element_forces_threaded(node_xy, elem_nodes, node_stress, elem_block_ptr, elem_colour_ptr, elem_colour_block,
                                node_force)
    else:
        for slot in range(elem_colour_block.shape[0]):
            block = elem_colour_block[slot]
            add_element_forces(node_xy, elem_nodes, node_stress, elem_block_ptr[block], elem_block_ptr[block + 1],
                               node_force)
    if beta <= 0.0:
        return 0.0
    half_beta_dt = 0.5 * beta * dt
    n_block = edge_block_ptr.shape[0] - 1
    block_power = np.zeros(n_block)
    if n_threads is not None:
        bond_forces_threaded(node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, edge_nodes,
                             edge_block_ptr, edge_colour_ptr, edge_colour_block, dt, half_beta_dt, min_bond_sq,
                             node_force, block_power)
    else:
        for slot in range(n_block):
            block = edge_colour_block[slot]
            block_power[block] = add_bond_forces(
                node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, edge_nodes, edge_block_ptr[block],
                edge_block_ptr[block + 1], dt, half_beta_dt, min_bond_sq, node_force)
    power = 0.0
    for block in range(n_block):
        power += block_power[block]
    return power


@parallel_inner_kernel
def element_forces_threaded(node_xy, elem_nodes, node_stress, elem_block_ptr, elem_colour_ptr, elem_colour_block,
                            node_force):
    """:func:`add_element_forces` of every block, colour after colour, a colour's blocks on threads."""
    for colour in range(elem_colour_ptr.shape[0] - 1):  # blocks of one colour share no node
        for slot in prange(elem_colour_ptr[colour], elem_colour_ptr[colour + 1]):
            block = elem_colour_block[slot]
            add_element_forces(node_xy, elem_nodes, node_stress, elem_block_ptr[block], elem_block_ptr[block + 1],
                               node_force)


@parallel_inner_kernel
def bond_forces_threaded(node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, edge_nodes, edge_block_ptr,
                         edge_colour_ptr, edge_colour_block, dt, half_beta_dt, min_bond_sq, node_force, block_power):
    """:func:`add_bond_forces` of every block, colour after colour, a colour's blocks on threads."""
    for colour in range(edge_colour_ptr.shape[0] - 1):
        for slot in prange(edge_colour_ptr[colour], edge_colour_ptr[colour + 1]):
            block = edge_colour_block[slot]
            block_power[block] = add_bond_forces(
                node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, edge_nodes, edge_block_ptr[block],
                edge_block_ptr[block + 1], dt, half_beta_dt, min_bond_sq, node_force)


@inner_kernel
def add_element_forces(node_xy, elem_nodes, node_stress, start, end, node_force):
    """node_force[I] -= A_e B_I^e^T sigma_bar_e for the elements start..end-1, formed as
    (2 A_e B_I^e)^T (sigma_bar_e / 2): twice the gradients from the coordinates,
    2 A_e b_I = y_J - y_K and 2 A_e c_I = x_K - x_J (``smoothing.scaled_gradients`` halved), and
    half the mean stress, whose 1/2 joins the mean's 1/3.  Halving is exact in floating point, so
    the products are those of A_e b_I sigma_bar_e to the bit, with six multiplications fewer per
    element.  The particle arrays are read through flat rows (``jit`` module doc)."""
    sixth = 1.0 / 6.0  # 1/3 halved, exactly
    xy, stress, force = node_xy.reshape(-1), node_stress.reshape(-1), node_force.reshape(-1)
    for e in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        i = np.uint64(elem_nodes[e, 0])
        j = np.uint64(elem_nodes[e, 1])
        k = np.uint64(elem_nodes[e, 2])
        i2, j2, k2 = i * TWO, j * TWO, k * TWO  # the rows of i, j, k in the (n, 2) arrays
        i4, j4, k4 = i * FOUR, j * FOUR, k * FOUR  # and in the (n, 4) stress
        sxx = (stress[i4 + FLAT_XX] + stress[j4 + FLAT_XX] + stress[k4 + FLAT_XX]) * sixth
        syy = (stress[i4 + FLAT_YY] + stress[j4 + FLAT_YY] + stress[k4 + FLAT_YY]) * sixth
        sxy = (stress[i4 + FLAT_XY] + stress[j4 + FLAT_XY] + stress[k4 + FLAT_XY]) * sixth
        xi, yi = xy[i2], xy[i2 + ONE]
        xj, yj = xy[j2], xy[j2 + ONE]
        xk, yk = xy[k2], xy[k2 + ONE]
        bi, bj, bk, ci, cj, ck = yj - yk, yk - yi, yi - yj, xk - xj, xi - xk, xj - xi
        force[i2] -= bi * sxx + ci * sxy
        force[i2 + ONE] -= bi * sxy + ci * syy
        force[j2] -= bj * sxx + cj * sxy
        force[j2 + ONE] -= bj * sxy + cj * syy
        force[k2] -= bk * sxx + ck * sxy
        force[k2 + ONE] -= bk * sxy + ck * syy


@inner_kernel
def add_bond_forces(node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, edge_nodes, start, end, dt,
                    half_beta_dt, min_bond_sq, node_force):
    """Add the forces of bonds start..end-1 (``stabilisation.bond_force``) into their nodes;
    their power (W/m)."""
    power = 0.0
    for bond in range(np.uint64(start), np.uint64(end)):  # unsigned: no negative-index wraparound code
        i = np.uint64(edge_nodes[bond, 0])
        j = np.uint64(edge_nodes[bond, 1])
        fx, fy, bond_power = bond_force(node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, i, j, dt,
                                        half_beta_dt, min_bond_sq)
        node_force[j, 0] += fx
        node_force[j, 1] += fy
        node_force[i, 0] -= fx
        node_force[i, 1] -= fy
        power += bond_power
    return power
