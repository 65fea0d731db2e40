"""Rank-deficiency stabilisation of nodal integration (Yuan et al.), bond form.

For every mesh bond i-j, node i's smoothed incremental deformation gradient
F_i = I + L_i dt maps the bond at the start of the step, x0_ij = x_ij - (v_j - v_i) dt, onto
where a linear velocity field would put it; the error projected on the current bond
direction e_ij = x_ij / |x_ij| is

    delta^i_ij = (F_i x0_ij - x_ij) . e_ij = dt (L_i x0_ij - (v_j - v_i)) . e_ij .

The pair force along e_ij (on j; the opposite on i) is

    f_ij = (beta / 2) (E_i A_i delta^i_ij + E_j A_j delta^j_ij) / |x0_ij|^2

with each node's own Young's modulus E (of its material row) and smoothing-cell area A.  Because delta is an
increment over one step, f is a bond viscosity eta = beta E dt / 2 acting on the part of the
relative velocity a linear field cannot explain: it only removes energy (its work is
returned so energy budgets can account for it), and at fixed beta it scales with dt.

The viscosity per bond grows as 1 / |x0|^2: for a bond much shorter than the spacing h
(two particles pressed together after a remesh) it exceeds what an explicit step can
integrate (c dt / m ~ beta/2 cfl^2 h^2/|x0|^2) and the run blows up.  |x0|^2 is therefore
bounded below by ``min_bond_sq`` = (h/2)^2, which changes nothing on ordinary bonds.

As a vector the force on j is f_ij e_ij; with e_ij = x_ij / |x_ij| both projections and the
direction combine into one factor, without a square root:

    F_ij = (beta dt / 2) [E_i A_i (L_i x0_ij - dv) . x_ij + E_j A_j (L_j x0_ij - dv) . x_ij]
           / (|x_ij|^2 max(|x0_ij|^2, min_bond_sq)) x_ij .

``nodal_force`` evaluates every bond once per step, in coloured blocks of bonds.
"""

from __future__ import annotations

import numpy as np

from spfem_core.jit import inline_kernel
from spfem_core.state import L_XX, L_XY, L_YX, L_YY


@inline_kernel
def bond_force(node_xy, node_v, node_L, node_area, node_material_row, mat_youngs, i, j, dt, half_beta_dt, min_bond_sq):
    """(F_x, F_y, power) of bond i-j: the force F_ij on j (module doc; -F_ij on i) and its power
    F_ij . (v_j - v_i) (W/m, <= 0 when the bond removes energy); zero for a bond of zero length."""
    dx = node_xy[j, 0] - node_xy[i, 0]
    dy = node_xy[j, 1] - node_xy[i, 1]
    dvx = node_v[j, 0] - node_v[i, 0]
    dvy = node_v[j, 1] - node_v[i, 1]
    x0x = dx - dvx * dt
    x0y = dy - dvy * dt
    length0_sq = x0x * x0x + x0y * x0y
    length_sq = dx * dx + dy * dy
    if length0_sq <= 0.0 or length_sq <= 0.0:
        return 0.0, 0.0, 0.0
    # (L x0 - dv) . x for node i and node j: the velocity error of each one's linear field along the bond
    err_i = ((node_L[i, L_XX] * x0x + node_L[i, L_XY] * x0y - dvx) * dx
             + (node_L[i, L_YX] * x0x + node_L[i, L_YY] * x0y - dvy) * dy)
    err_j = ((node_L[j, L_XX] * x0x + node_L[j, L_XY] * x0y - dvx) * dx
             + (node_L[j, L_YX] * x0x + node_L[j, L_YY] * x0y - dvy) * dy)
    ea_i = mat_youngs[np.uint64(node_material_row[i])] * node_area[i]  # unsigned: no wraparound code
    ea_j = mat_youngs[np.uint64(node_material_row[j])] * node_area[j]
    factor = half_beta_dt * (ea_i * err_i + ea_j * err_j) / (length_sq * max(length0_sq, min_bond_sq))
    fx = factor * dx
    fy = factor * dy
    return fx, fy, fx * dvx + fy * dvy
