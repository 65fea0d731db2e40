"""Forces on the soil skeleton besides gravity and its own stress: pore water, ponded water,
surface loads.

**Effective stress.**  The particles carry the effective stress sigma' (what the yield function
sees); equilibrium is in total stress sigma = sigma' - u I (tension positive, pore pressure u > 0
in compression).  The internal force of the total stress is that of sigma' plus

    f_I^u = sum_e A_e B_I^e^T (u_bar_e I) = sum_e A_e u_bar_e (b_I^e, c_I^e),   u_bar_e the vertex mean.

The pore pressure of particle k, from its piezometric line y_w(x) (the study's, or its
material's own) fixed in space (drained, steady water: a particle that moves takes the pore
pressure of where it is now):

    u_k = gamma_w max(y_w(x_k) - y_k, 0)      (beyond the line's ends, the end heights)

plus a pore pressure carried by the particle itself (``node_pore_pressure_pa``: ru).

**Ponded water** at level L loads the current boundary (the alpha shape, so it follows the
deforming surface) between two abscissae (a reservoir on one face of a dam: edges whose midpoint
x lies outside [x_min, x_max] are dry).  On a boundary edge a -> b (material on its left) the pressure
p = gamma_w max(L - y, 0) is linear along the edge, clipped at the water line, and pushes along
the inward normal (-dy, dx) / |ab|:

    f_a = (-dy, dx) int_0^1 p(t) (1 - t) dt,     f_b = (-dy, dx) int_0^1 p(t) t dt.

**Surface loads** are forces carried by the particles (``node_force_n``), constant, or grown
linearly from zero over ``ramp_time_s`` of stage time.

**Gravity stages** (``at_initial_positions``) evaluate both water pressures at the particles'
initial positions x - u: the settlement of a relaxation from zero stress is an artefact that the
next stage discards, and the relaxed effective stress must balance the pore pressure of the
positions the next stage starts from (otherwise it starts out of balance by gamma_w times the
settlement).

The work the loads do over a step is sum_k f_k^n . v_k^{n+1/2} dt (the leapfrog displacement of
the step), so minus its sum is a potential that closes the energy budget like gravity's.
"""

from __future__ import annotations

from spfem_core.jit import inner_kernel
from spfem_core.smoothing import scaled_gradients


@inner_kernel
def phreatic_height(line_xy, first, end, x):
    """y_w(x) of the polyline ``line_xy[first:end]`` (x increasing), constant beyond its ends."""
    if x <= line_xy[first, 0]:
        return line_xy[first, 1]
    for i in range(first + 1, end):
        if x <= line_xy[i, 0]:
            x0 = line_xy[i - 1, 0]
            t = (x - x0) / (line_xy[i, 0] - x0)
            return line_xy[i - 1, 1] + t * (line_xy[i, 1] - line_xy[i - 1, 1])
    return line_xy[end - 1, 1]


@inner_kernel
def _edge_pressure_integrals(pa, pb, ya, yb, level):
    """(int_0^1 p (1 - t) dt, int_0^1 p t dt) of p = pa + t (pb - pa) clipped at the water line."""
    a_wet = ya < level
    b_wet = yb < level
    if a_wet and b_wet:
        return (2.0 * pa + pb) / 6.0, (pa + 2.0 * pb) / 6.0
    if a_wet:  # wet from t = 0 to t_w, p falls linearly from pa to 0
        t_w = (level - ya) / (yb - ya)
        return pa * t_w * (0.5 - t_w / 6.0), pa * t_w * t_w / 6.0
    if b_wet:  # mirror: wet from t = 1 - t_w to 1
        t_w = (level - yb) / (ya - yb)
        return pb * t_w * t_w / 6.0, pb * t_w * (0.5 - t_w / 6.0)
    return 0.0, 0.0


@inner_kernel
def add_external_forces(node_xy, node_disp, elem_nodes, loads, time_s, node_pore_pressure, node_force_ext,
                        node_force):
    """Fill ``node_pore_pressure`` (u_k, Pa) and ``node_force_ext`` (the loads' forces, N/m) and add
    the latter to ``node_force`` (module doc); ``loads`` a ``state.ExternalLoads``, ``node_disp`` the
    displacement since the initial positions (used with ``loads.at_initial_positions``), ``time_s`` the
    stage time of the step (for the load ramp)."""
    n = node_xy.shape[0]
    gamma_w = loads.water_unit_weight_n_m3
    lines = loads.phreatic_xy_m
    start = loads.phreatic_start
    shift = 1.0 if loads.at_initial_positions else 0.0
    factor = 1.0
    if loads.ramp_time_s > 0.0 and time_s < loads.ramp_time_s:
        factor = time_s / loads.ramp_time_s
    for k in range(n):
        u = loads.node_pore_pressure_pa[k]
        line = loads.node_phreatic_line[k]
        if line >= 0:
            head = (phreatic_height(lines, start[line], start[line + 1], node_xy[k, 0] - shift * node_disp[k, 0])
                    - (node_xy[k, 1] - shift * node_disp[k, 1]))
            if head > 0.0:
                u += gamma_w * head
        node_pore_pressure[k] = u
        node_force_ext[k, 0] = factor * loads.node_force_n[k, 0]
        node_force_ext[k, 1] = factor * loads.node_force_n[k, 1]
    third = 1.0 / 3.0
    for e in range(elem_nodes.shape[0]):
        i = elem_nodes[e, 0]
        j = elem_nodes[e, 1]
        k = elem_nodes[e, 2]
        u_bar = (node_pore_pressure[i] + node_pore_pressure[j] + node_pore_pressure[k]) * third
        if u_bar == 0.0:
            continue
        bi, bj, bk, ci, cj, ck = scaled_gradients(node_xy, i, j, k)
        node_force_ext[i, 0] += u_bar * bi
        node_force_ext[i, 1] += u_bar * ci
        node_force_ext[j, 0] += u_bar * bj
        node_force_ext[j, 1] += u_bar * cj
        node_force_ext[k, 0] += u_bar * bk
        node_force_ext[k, 1] += u_bar * ck
    level = loads.pond_level_m
    if level == level:  # not NaN: water stands on the surface
        edges = loads.boundary_edges
        x_min = loads.pond_x_range_m[0]
        x_max = loads.pond_x_range_m[1]
        for b in range(edges.shape[0]):
            a = edges[b, 0]
            c = edges[b, 1]
            ya = node_xy[a, 1] - shift * node_disp[a, 1]
            yc = node_xy[c, 1] - shift * node_disp[c, 1]
            if ya >= level and yc >= level:
                continue
            x_mid = 0.5 * (node_xy[a, 0] - shift * node_disp[a, 0] + node_xy[c, 0] - shift * node_disp[c, 0])
            if x_mid < x_min or x_mid > x_max:
                continue
            wa, wc = _edge_pressure_integrals(gamma_w * (level - ya), gamma_w * (level - yc), ya, yc, level)
            nx = -(yc - ya)
            ny = (node_xy[c, 0] - shift * node_disp[c, 0]) - (node_xy[a, 0] - shift * node_disp[a, 0])
            node_force_ext[a, 0] += wa * nx
            node_force_ext[a, 1] += wa * ny
            node_force_ext[c, 0] += wc * nx
            node_force_ext[c, 1] += wc * ny
    for k in range(n):
        node_force[k, 0] += node_force_ext[k, 0]
        node_force[k, 1] += node_force_ext[k, 1]


@inner_kernel
def external_power(node_v, node_force_ext):
    """sum_k f_k . v_k (W/m): with the velocities after the leapfrog update, the loads' work rate
    over the step just taken."""
    power = 0.0
    for k in range(node_v.shape[0]):
        power += node_force_ext[k, 0] * node_v[k, 0] + node_force_ext[k, 1] * node_v[k, 1]
    return power
