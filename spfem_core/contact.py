"""Rigid walls: straight segments with Coulomb friction, predictor-corrector contact.

A wall is the segment p1 -> p2, a row (x1, y1, x2, y2) of ``wall_xy`` (m), with a Coulomb
coefficient mu >= 0 in ``wall_friction``.  Material lies on the LEFT of p1 -> p2: the unit
normal

    n = (-(y2 - y1), x2 - x1) / L,   t = (x2 - x1, y2 - y1) / L,   L = |p2 - p1|

points into the material (a floor (-10, 0) -> (10, 0) holds material above it; the walls of a
container are listed counter-clockwise around the material).  Walls are fixed.

For a particle at x (start of the step) with the predicted velocity v (after internal and
external forces), the projection parameter and the gap are

    s = (x - p1) . t / L,   g = (x - p1) . n .

A wall acts when -tol <= s <= 1 + tol (end tolerance tol = reach / (10 L), i.e. reach / 10 in
metres), g >= -reach (a wall is a one-sided surface of thickness ``reach``: particles further
behind it are ignored) and the predicted gap is negative, g + dt v . n < 0.  Then (ESPFEM2D
eq. 19-21 written as velocity changes, f = m dv / dt):

    v_n' = -g / dt                       lands exactly on the wall (pushes out if g < 0)
    dv_n = v_n' - v_n >= 0
    v_t' = 0                             if |v_t| <= mu dv_n  (sticking, eq. 20)
    v_t' = v_t - mu dv_n sign(v_t)       otherwise            (Coulomb cap |f_t| <= mu |f_n|)

Several walls are applied once each, in table order; each sees the velocity corrected by the
walls before it.  For a corner of two perpendicular walls this is exact (the second normal
correction is tangential to the first wall, and friction only shrinks velocity components).
For walls meeting at an acute angle the last wall wins: the particle may end the step slightly
behind an earlier wall and is pushed back out (g < 0 branch) at the next step.
"""

from __future__ import annotations

import math

from spfem_core.jit import kernel


@kernel
def wall_contact_velocity(px, py, vx, vy, dt, wall_xy, wall_friction, reach):
    """Correct the predicted velocity (vx, vy) of a particle at (px, py) for every wall (module
    doc): v_n' = -g/dt, |dv_t| <= mu dv_n.  Returns (vx', vy', sum of dv_n over the walls), the
    normal impulse per unit mass (m/s; normal force = m dv_n / dt)."""
    dvn_total = 0.0
    end_tol = 0.1 * reach
    for w in range(wall_xy.shape[0]):
        x1 = wall_xy[w, 0]
        y1 = wall_xy[w, 1]
        dx = wall_xy[w, 2] - x1
        dy = wall_xy[w, 3] - y1
        length = math.sqrt(dx * dx + dy * dy)
        if not (length > 0.0):
            continue
        tx = dx / length
        ty = dy / length
        nx = -ty
        ny = tx
        rx = px - x1
        ry = py - y1
        along = rx * tx + ry * ty  # s L, metres along the segment
        if along < -end_tol or along > length + end_tol:
            continue
        gap = rx * nx + ry * ny
        if gap < -reach:
            continue
        vn = vx * nx + vy * ny
        if not (gap + dt * vn < 0.0):
            continue
        vn_new = -gap / dt
        dvn = vn_new - vn
        vt = vx * tx + vy * ty
        cap = wall_friction[w] * dvn
        if abs(vt) <= cap:
            vt_new = 0.0
        elif vt > 0.0:
            vt_new = vt - cap
        else:
            vt_new = vt + cap
        vx = vn_new * nx + vt_new * tx
        vy = vn_new * ny + vt_new * ty
        dvn_total += dvn
    return vx, vy, dvn_total

