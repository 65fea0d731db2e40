"""Bishop's simplified method on slip circles over a rastered section: the compiled loop of the
limit-equilibrium search (``workflows.fos.critical_circle``, whose module doc describes the raster, the
section turned to face +x and the admissibility of a circle).

A circle (xc, yc, R) is cut into ``slices`` slices between the ground's crossings (each found by
``CROSSING_BISECTIONS`` bisections); slice i of width b_i, weight W_i (the mean unit weight of its raster
column from the base up to the ground, times its height and width), base inclination a_i, pore
pressure u_i and the strength c_i, tan phi_i of the cell at its base gives

    F = sum_i (c_i b_i + max(W_i - u_i b_i, 0) tan(phi_i)) / m_i  /  sum_i W_i sin(a_i),
    m_i = cos(a_i) + sin(a_i) tan(phi_i) / F            (fixed point from F = 1, to 1e-7)

F = inf marks a circle that is not admissible (module doc of the search).  The raster is regular: column
j at x_0 + j cell, row r from ``base`` + r cell.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.jit import inner_kernel, kernel

CROSSING_BISECTIONS = 26
"""Bisections of the interval (at most a raster cell) in which an arc meets the ground: 1e-8 of a cell."""
FIXED_POINT_ITERATIONS = 60
FIXED_POINT_TOLERANCE = 1e-7
SMALLEST_M = 0.2
"""A slice whose m_i falls to this is not admissible (Bishop's method breaks down at the toe of a steep
exit; the usual guard)."""


@inner_kernel
def _ground_at(x, x_0, cell, ground, void):
    """The ground's height at one abscissa: linear between the raster columns; -inf over a void column."""
    last = ground.shape[0] - 1
    position = min(max((x - x_0) / cell, 0.0), float(last))
    if void[int(position + 0.5)]:
        return -math.inf
    left = min(int(position), last - 1)
    return ground[left] + (ground[left + 1] - ground[left]) * (position - left)


@inner_kernel
def _crossing(outside, inside, xc, yc, radius, x_0, cell, ground, void):
    """Where the arc meets the ground between an abscissa outside the ground and one inside it."""
    for _ in range(CROSSING_BISECTIONS):
        middle = 0.5 * (outside + inside)
        depth = _ground_at(middle, x_0, cell, ground, void) - (yc - math.sqrt(max(radius * radius - (middle - xc) ** 2,
                                                                                   0.0)))
        if depth <= 0.0:
            outside = middle
        else:
            inside = middle
    return 0.5 * (outside + inside)


@kernel
def bishop_circles(xc, yc, radius, x, ground, void, base, cell, columns, cumulative, material, pore, cohesion,
                   tan_phi, slices):
    """(k, 3): F, entry and exit abscissa of each circle (xc[i], yc[i], radius[i]) (module doc); the
    raster's columns x (ascending, regular), their ground and void flags, the raster column ``columns[j]``
    of column j, ``cumulative`` (rows + 1, raster columns) the unit weight summed up from the base,
    ``material`` and ``pore`` per cell, ``cohesion`` and ``tan_phi`` per material (the last: no soil)."""
    out = np.empty((xc.shape[0], 3))
    out[:, 0] = math.inf
    out[:, 1:] = math.nan
    n = x.shape[0]
    x_0 = x[0]
    rows = material.shape[0]
    for k in range(xc.shape[0]):
        cx, cy, r = xc[k], yc[k], radius[k]
        if max(_ground_at(cx - r, x_0, cell, ground, void), _ground_at(cx + r, x_0, cell, ground, void)) > cy:
            continue  # the circle meets the ground on its upper half: no closed block
        first, last, count, gap = -1, -1, 0, False
        for j in range(n):
            if x[j] > cx - r and x[j] < cx + r and not void[j]:
                if cy - math.sqrt(max(r * r - (x[j] - cx) ** 2, 0.0)) < ground[j] - 1e-9:
                    if last >= 0 and j != last + 1:
                        gap = True
                    if first < 0:
                        first = j
                    last = j
                    count += 1
        if count < 3 or gap:  # too short, or the circle leaves and re-enters the ground
            continue
        left = _crossing(max(x[first - 1], cx - r) if first > 0 else cx - r, x[first], cx, cy, r, x_0, cell,
                         ground, void)
        right = _crossing(min(x[last + 1], cx + r) if last + 1 < n else cx + r, x[last], cx, cy, r, x_0, cell,
                          ground, void)
        step = (right - left) / slices
        weight = np.empty(slices)
        sin_a = np.empty(slices)
        cos_a = np.empty(slices)
        resisting = np.empty(slices)
        tan_base = np.empty(slices)
        admissible = True
        driving = 0.0
        for i in range(slices):
            low = left + i * step
            high = right if i == slices - 1 else left + (i + 1) * step
            middle = 0.5 * (high + low)
            width = high - low
            under = max(r * r - (middle - cx) ** 2, 0.0)
            y_base = cy - math.sqrt(under)
            if y_base < base - 1e-9:
                admissible = False
                break
            column_index = min(max(int(np.rint((middle - x_0) / cell)), 0), n - 1)
            if void[column_index]:  # a slice over no soil (beside a free side)
                admissible = False
                break
            y_ground = _ground_at(middle, x_0, cell, ground, void)
            column = columns[column_index]
            row = min(max(int(math.floor((y_base - base) / cell)), 0), rows - 1)
            top = max(min(max(int(math.floor((y_ground - 0.5 * cell - base) / cell)), 0), rows - 1), row)
            w = (cumulative[top + 1, column] - cumulative[row, column]) / (top - row + 1) * (y_ground - y_base) * width
            m = material[row, column]
            c = cohesion[m]
            if not math.isfinite(c):
                admissible = False
                break
            alpha = math.atan2(cx - middle, math.sqrt(max(under, 1e-12)))
            weight[i] = w
            sin_a[i] = math.sin(alpha)
            cos_a[i] = math.cos(alpha)
            tan_base[i] = tan_phi[m]
            resisting[i] = c * width + max(w - pore[row, column] * width, 0.0) * tan_phi[m]
            driving += w * sin_a[i]
        if not admissible or driving <= 0.0:
            continue
        fos = 1.0
        for _ in range(FIXED_POINT_ITERATIONS):
            total = 0.0
            for i in range(slices):
                m_i = cos_a[i] + sin_a[i] * tan_base[i] / fos
                if m_i <= SMALLEST_M:
                    admissible = False
                    break
                total += resisting[i] / m_i
            if not admissible:
                break
            new = total / driving
            if abs(new - fos) < FIXED_POINT_TOLERANCE:
                fos = new
                break
            fos = new
        if admissible:
            out[k, 0] = fos
            out[k, 1] = left
            out[k, 2] = right
    return out
