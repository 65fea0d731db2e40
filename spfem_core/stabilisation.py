"""Rank-deficiency stabilisation of nodal integration (Yuan et al.), bond form.

For every mesh bond i-j, node i's smoothed incremental deformation gradient
F_i = I + L_i dt maps the bond at the start of the step, x0_ij = x_ij - (v_j - v_i) dt, onto
where a linear velocity field would put it; the error projected on the current bond
direction e_ij = x_ij / |x_ij| is

    delta^i_ij = (F_i x0_ij - x_ij) . e_ij = dt (L_i x0_ij - (v_j - v_i)) . e_ij .

The pair force along e_ij (on j; the opposite on i) is

    f_ij = (beta / 2) (E_i A_i delta^i_ij + E_j A_j delta^j_ij) / |x0_ij|^2

with each node's own Young's modulus E and smoothing-cell area A.  Because delta is an
increment over one step, f is a bond viscosity eta = beta E dt / 2 acting on the part of the
relative velocity a linear field cannot explain: it only removes energy (its work is
returned so energy budgets can account for it), and at fixed beta it scales with dt.

The viscosity per bond grows as 1 / |x0|^2: for a bond much shorter than the spacing h
(two particles pressed together after a remesh) it exceeds what an explicit step can
integrate (c dt / m ~ beta/2 cfl^2 h^2/|x0|^2) and the run blows up.  |x0|^2 is therefore
bounded below by ``min_bond_sq`` = (h/2)^2, which changes nothing on ordinary bonds.

Two parallel loops (``jit`` module doc): one over bonds stores each bond's force on each end
at that end's entry of the node->node lists (``Mesh.edge_entry``), one over nodes adds its
contiguous range of entries (its bonds in ascending order of the neighbour).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from spfem_core.jit import PARALLEL_CHUNK, parallel_inner_kernel


@parallel_inner_kernel
def add_stabilisation_force(
    node_xy, node_v, node_L, node_area, node_material, mat_youngs, edge_nodes, edge_entry, node_node_ptr, beta, dt,
    min_bond_sq, bond_force, node_force
):
    """Add the bond forces f_ij over every mesh edge (i, j) to node_force (``bond_force``
    (2 n_edges, 2) keeps the force on each end at its entry); return their power sum f . v
    (W/m; negative when the bonds remove energy, as they do on a whole mesh)."""
    half_beta = 0.5 * beta
    n_edges = edge_nodes.shape[0]
    n_chunk = (n_edges + PARALLEL_CHUNK - 1) // PARALLEL_CHUNK
    chunk_power = np.zeros(n_chunk)
    for chunk in prange(n_chunk):
        power = 0.0
        for b in range(chunk * PARALLEL_CHUNK, min((chunk + 1) * PARALLEL_CHUNK, n_edges)):
            i = edge_nodes[b, 0]
            j = edge_nodes[b, 1]
            dx = node_xy[j, 0] - node_xy[i, 0]
            dy = node_xy[j, 1] - node_xy[i, 1]
            dvx = node_v[j, 0] - node_v[i, 0]
            dvy = node_v[j, 1] - node_v[i, 1]
            x0x = dx - dvx * dt
            x0y = dy - dvy * dt
            length0_sq = x0x * x0x + x0y * x0y
            length_sq = dx * dx + dy * dy
            at_i = edge_entry[b, 0]
            at_j = edge_entry[b, 1]
            if length0_sq <= 0.0 or length_sq <= 0.0:
                bond_force[at_i, 0] = 0.0
                bond_force[at_i, 1] = 0.0
                bond_force[at_j, 0] = 0.0
                bond_force[at_j, 1] = 0.0
                continue
            inv_length = 1.0 / math.sqrt(length_sq)
            ex = dx * inv_length
            ey = dy * inv_length
            # velocity error of the linear field of node i / node j along e, times dt
            err_i = ((node_L[i, 0] * x0x + node_L[i, 1] * x0y - dvx) * ex
                     + (node_L[i, 2] * x0x + node_L[i, 3] * x0y - dvy) * ey)
            err_j = ((node_L[j, 0] * x0x + node_L[j, 1] * x0y - dvx) * ex
                     + (node_L[j, 2] * x0x + node_L[j, 3] * x0y - dvy) * ey)
            ea_i = mat_youngs[node_material[i]] * node_area[i]
            ea_j = mat_youngs[node_material[j]] * node_area[j]
            f = half_beta * dt * (ea_i * err_i + ea_j * err_j) / max(length0_sq, min_bond_sq)
            fx = f * ex
            fy = f * ey
            bond_force[at_i, 0] = -fx
            bond_force[at_i, 1] = -fy
            bond_force[at_j, 0] = fx
            bond_force[at_j, 1] = fy
            power += fx * dvx + fy * dvy
        chunk_power[chunk] = power
    for n in prange(node_force.shape[0]):
        fx = node_force[n, 0]
        fy = node_force[n, 1]
        for p in range(node_node_ptr[n], node_node_ptr[n + 1]):
            fx += bond_force[p, 0]
            fy += bond_force[p, 1]
        node_force[n, 0] = fx
        node_force[n, 1] = fy
    power = 0.0
    for chunk in range(n_chunk):
        power += chunk_power[chunk]
    return power
