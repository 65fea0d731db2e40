"""Critical time step of the explicit scheme.

    dt_crit = min over elements of  h_alt,e / c_p,e,    h_alt,e = 2 A_e / (longest edge of e)

with c_p = sqrt((K + 4G/3) / rho) the fastest P-wave speed among the element's particles.
The run uses dt = cfl * dt_crit (or a given dt, refused when above dt_crit).
"""

from __future__ import annotations

import math

from spfem_core.jit import kernel


@kernel
def critical_time_step(node_xy, elem_nodes, node_wave_speed):
    """min_e h_alt,e / c_p,e over all elements (s); inf for an empty mesh."""
    dt_min = math.inf
    for e in range(elem_nodes.shape[0]):
        i = elem_nodes[e, 0]
        j = elem_nodes[e, 1]
        k = elem_nodes[e, 2]
        ax = node_xy[j, 0] - node_xy[i, 0]
        ay = node_xy[j, 1] - node_xy[i, 1]
        bx = node_xy[k, 0] - node_xy[j, 0]
        by = node_xy[k, 1] - node_xy[j, 1]
        cx = node_xy[i, 0] - node_xy[k, 0]
        cy = node_xy[i, 1] - node_xy[k, 1]
        two_area = abs(ax * (-cy) - (-cx) * ay)
        longest_sq = max(ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy)
        altitude = two_area / math.sqrt(longest_sq)
        speed = max(node_wave_speed[i], node_wave_speed[j], node_wave_speed[k])
        dt = altitude / speed
        if dt < dt_min:
            dt_min = dt
    return dt_min
