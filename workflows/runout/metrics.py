"""What a runout did, from its final state and its records.

The slide goes down the slope: +x when the ground surface is lower at the right end of the domain
than at the left (the slope form's crest is on the left), -x otherwise
(``spfem_core.geometry.downslope_sign``); below, x is measured along that direction.  With y_0(x) the initial ground surface (the polygon's upper boundary) and y(x) the
final one (the upper envelope of the particles in the mesh, in bins of width h), and t the deposit
thickness (``deposit_thickness_m``):

- ``runout_m``: how far the toe advanced, x_front - x_toe, with x_front the furthest x where
  y(x) - y_0(x) > t and x_toe the initial toe (where the initial surface first reaches its lowest
  height); 0 if the surface rose nowhere beyond the toe;
- ``retrogression_m``: how far the scarp retreated behind the crest, x_crest - x_scarp, with x_scarp
  the x furthest back where y_0(x) - y(x) > t and x_crest the initial crest (the last x at the
  highest initial height); 0 if it did not reach behind the crest;
- ``sliding_mass_area_m2``: the initial area (m_k / rho_k) of the particles that moved more than
  ``moved_threshold_m``;
- ``max_speed_m_s`` and ``max_speed_time_s``: the largest particle speed recorded and when;
- ``time_to_rest_s`` (:mod:`workflows.runout.rest`), NaN if the flow was still moving at the end;
- ``potential_released_j_m`` = -(gravity + load potential) at the end, and
  ``energy_budget_error`` = (sum of every energy column at the end - at the start) / released;
- ``surface_x``, ``surface_height``: the final surface profile.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.energy_budget import ENERGY_GRAVITY_POTENTIAL, ENERGY_LOAD_POTENTIAL
from spfem_core.geometry import downslope_sign, surface_height_m
from workflows.collapse.metrics import upper_envelope
from workflows.runout.rest import time_to_rest_s


def final_surface(node_xy_m: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, height): the highest particle of every occupied bin of width h, by x."""
    _, top = upper_envelope(node_xy_m, spacing_m)
    return node_xy_m[top, 0], node_xy_m[top, 1]


def surface_change(polygon_m, surface_x_m: np.ndarray, surface_y_m: np.ndarray, sign: float):
    """(x along the slide, y - y_0 at the surface points, initial toe x, initial crest x), all along
    the slide direction (x multiplied by ``sign``)."""
    change = surface_y_m - surface_height_m(polygon_m, surface_x_m)
    grid = np.linspace(min(x for x, _ in polygon_m), max(x for x, _ in polygon_m), 4001)
    ground = surface_height_m(polygon_m, grid)
    along = sign * grid
    order = np.argsort(along)
    along, ground = along[order], ground[order]
    tol = 1e-9 * (1.0 + np.nanmax(np.abs(ground)))
    toe = along[np.flatnonzero(ground <= np.nanmin(ground) + tol)[0]]
    crest = along[np.flatnonzero(ground >= np.nanmax(ground) - tol)[-1]]
    return sign * surface_x_m, change, float(toe), float(crest)


def runout_summary(polygon_m, node_xy_m, node_displacement_m, node_initial_area_m2, spacing_m: float,
                   time_s, energy_j_per_m, max_speed_m_s, *, deposit_thickness_m: float, moved_threshold_m: float,
                   rest_fraction: float, rest_window_s: float) -> dict[str, float]:
    """The scalars of the module doc, keys with units."""
    sign = downslope_sign(polygon_m) or -1.0
    surface_x, surface_y = final_surface(node_xy_m, spacing_m)
    along, change, toe, crest = surface_change(polygon_m, surface_x, surface_y, sign)
    valid = np.isfinite(change)
    raised = along[valid & (change > deposit_thickness_m) & (along > toe)]
    lowered = along[valid & (change < -deposit_thickness_m)]
    moved = np.hypot(node_displacement_m[:, 0], node_displacement_m[:, 1]) > moved_threshold_m
    speed_at = int(np.argmax(max_speed_m_s)) if max_speed_m_s.size else 0
    potential = energy_j_per_m[:, ENERGY_GRAVITY_POTENTIAL] + energy_j_per_m[:, ENERGY_LOAD_POTENTIAL]
    released = float(-potential[-1])
    total = energy_j_per_m.sum(axis=1)
    return {
        "runout_m": float(raised.max() - toe) if raised.size else 0.0,
        "retrogression_m": float(max(crest - lowered.min(), 0.0)) if lowered.size else 0.0,
        "sliding_mass_area_m2": float(node_initial_area_m2[moved].sum()),
        "max_speed_m_s": float(max_speed_m_s[speed_at]) if max_speed_m_s.size else 0.0,
        "max_speed_time_s": float(time_s[speed_at]) if max_speed_m_s.size else 0.0,
        "time_to_rest_s": time_to_rest_s(time_s, energy_j_per_m, rest_fraction, rest_window_s),
        "potential_released_j_m": released,
        "energy_budget_error": float((total[-1] - total[0]) / released) if released > 0.0 else math.nan,
        "deposit_thickness_m": float(deposit_thickness_m),
        "moved_threshold_m": float(moved_threshold_m),
    }
