"""Scalar metrics of a column collapse from particle data (pure numpy).

Conventions: positions in m, the wall at x = 0, the base at y = 0, flow towards +x; the
particles are the nodes of a mesh whose boundary is the free surface, so the top particles
ARE on the surface and the surface is their upper envelope, nothing added.  Pass only the
particles attached to the mesh (airborne particles would raise the envelope).

Bins.  Columns of width h (the particle spacing) are centred at x = k h (k integer), so the
lattice columns of a cloud anchored at the wall sit at bin centres, never on bin edges.
Rows for the failure line are centred at y = k h in the same way.

Definitions (h = spacing):

- surface profile: per x bin, the particle with the largest y; the profile point is that
  particle's own (x, y).  Empty bins have height 0 at their centre.
- main deposit: the particles sorted by x from the wall outward up to the first gap of more
  than 2 h between successive x; the particles beyond are isolated and ignored.  The deposit
  profile is the envelope of its occupied bins (empty bins inside the deposit are bridged by
  linear interpolation), followed by height 0 at the deposit's front x_front (the largest x
  of its particles) and beyond.
- runout at thickness t: scanning the deposit profile from the wall outward, the x where the
  height first drops below t, linearly interpolated between the two profile points around
  the crossing; x_front when the profile never drops below t; NaN when the height is below t
  already at the wall.
- wall height: max y of the particles with x < h.
- RMS surface error: sqrt(mean((H(x_r) - y_r)^2)) over all reference points, H the deposit
  profile (0 beyond the front).
- failure line (initial configuration): per row, the first moved particle (smallest initial
  x with |u| > threshold); the boundary point is the midpoint between it and the nearest
  unmoved particle on its left in the same row.  Rows without a moved particle, or whose
  first moved particle has no unmoved particle to its left (the whole row moved, no boundary
  inside the column), are ignored.  x = a + b y fitted by least squares; the angle from
  horizontal is atan2(1, -b) (positive, below 90 deg, for a line rising towards the wall);
  the base intercept is a.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.spatial import KDTree

from workflows.collapse.experiment import GRANULAR_SURFACE_XY_M

GAP_SPACINGS = 2.0
"""A gap in x of more than this many spacings ends the main deposit."""


# --------------------------------------------------------------------------------------
# input checks and helpers
# --------------------------------------------------------------------------------------


def _xy(array, name: str) -> np.ndarray:
    array = np.asarray(array, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (n, 2), got {array.shape}")
    if array.shape[0] == 0:
        raise ValueError(f"{name}: no particles")
    return array


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: must be finite and > 0, got {value}")
    return value


def _bin_index(coordinate_m: np.ndarray, spacing_m: float) -> np.ndarray:
    """Index k of the bin [(k - 1/2) h, (k + 1/2) h) holding each coordinate."""
    return np.floor(coordinate_m / spacing_m + 0.5).astype(np.int64)


def upper_envelope(node_xy_m: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(bin index, particle index) of the highest particle of every occupied x bin, by bin."""
    k = _bin_index(node_xy_m[:, 0], spacing_m)
    order = np.lexsort((node_xy_m[:, 1], k))
    k_sorted = k[order]
    last = np.r_[np.flatnonzero(k_sorted[1:] != k_sorted[:-1]), k_sorted.size - 1]
    return k_sorted[last], order[last]


def _main_deposit(node_xy_m: np.ndarray, spacing_m: float) -> np.ndarray:
    """The particles of the main deposit: sorted by x from the wall, up to the first x gap > 2 h."""
    x = node_xy_m[:, 0]
    order = np.argsort(x, kind="stable")
    gaps = np.flatnonzero(np.diff(x[order]) > GAP_SPACINGS * spacing_m)
    end = gaps[0] + 1 if gaps.size else x.size
    return node_xy_m[order[:end]]


def _deposit_profile(node_xy_m: np.ndarray, spacing_m: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(x, height, x_front) of the main deposit's profile; height 0 at x_front if x_front is past the last point."""
    deposit_xy_m = _main_deposit(node_xy_m, spacing_m)
    _, top = upper_envelope(deposit_xy_m, spacing_m)
    x_m, height_m = deposit_xy_m[top, 0], deposit_xy_m[top, 1]
    x_front_m = float(deposit_xy_m[:, 0].max())
    if x_front_m > x_m[-1]:
        x_m, height_m = np.r_[x_m, x_front_m], np.r_[height_m, 0.0]
    return x_m, height_m, x_front_m


def _deposit_height(node_xy_m: np.ndarray, spacing_m: float, x_query_m: np.ndarray) -> np.ndarray:
    x_m, height_m, _ = _deposit_profile(node_xy_m, spacing_m)
    return np.interp(x_query_m, x_m, height_m, left=height_m[0], right=0.0)


def estimate_spacing_m(node_xy_m) -> float:
    """Median nearest-neighbour distance of the particles (the nominal spacing of a lattice-like cloud)."""
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    if node_xy_m.shape[0] < 2:
        raise ValueError("node_xy_m: need at least two particles to estimate a spacing")
    distance, _ = KDTree(node_xy_m).query(node_xy_m, k=2)
    return float(np.median(distance[:, 1]))


# --------------------------------------------------------------------------------------
# surface metrics
# --------------------------------------------------------------------------------------


def surface_profile(node_xy_m, spacing_m: float, x_grid_m=None) -> tuple[np.ndarray, np.ndarray]:
    """Free-surface height as a function of x, (x_m, height_m).

    Bins of width h = ``spacing_m`` centred at x = k h, from the wall bin (k = 0, or the
    lowest occupied bin if particles lie behind the wall) to the last occupied bin.  In an
    occupied bin the point is the highest particle's own (x, y): the upper envelope of the
    particles, nothing added (surface particles lie on the free surface).  An empty bin gives
    height 0 at its centre.  With ``x_grid_m`` the profile is linearly interpolated onto it
    (height of the first point before it, 0 past the last).  All particles count, isolated
    ones included; the deposit metrics below ignore those.
    """
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    spacing_m = _positive(spacing_m, "spacing_m")
    k_top, top = upper_envelope(node_xy_m, spacing_m)
    k_first = min(0, int(k_top[0]))
    n_bins = int(k_top[-1]) - k_first + 1
    x_m = (np.arange(n_bins) + k_first) * spacing_m
    height_m = np.zeros(n_bins)
    x_m[k_top - k_first] = node_xy_m[top, 0]
    height_m[k_top - k_first] = node_xy_m[top, 1]
    if x_grid_m is None:
        return x_m, height_m
    x_grid_m = np.asarray(x_grid_m, dtype=np.float64)
    return x_grid_m, np.interp(x_grid_m, x_m, height_m, left=height_m[0], right=0.0)


def wall_height(node_xy_m, spacing_m: float) -> float:
    """Surface height at the wall: the largest y of the particles with x < h (0 if there are none)."""
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    spacing_m = _positive(spacing_m, "spacing_m")
    near_wall = node_xy_m[:, 0] < spacing_m
    return float(node_xy_m[near_wall, 1].max()) if near_wall.any() else 0.0


def runout(node_xy_m, spacing_m: float, thickness_m: float) -> float:
    """Runout at ``thickness_m``: the largest x where the deposit is still that thick.

    The deposit profile (main deposit: isolated particles beyond an x gap of more than 2 h
    ignored; empty bins inside bridged) is scanned from the wall outward; the runout is the x
    where its height first drops below ``thickness_m``, linearly interpolated between the
    two profile points around the crossing.  The profile ends with height 0 at the deposit's
    front (its largest particle x); if the envelope never drops below the threshold before
    that, the runout is the front.  NaN when the height at the wall is already below it.
    """
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    spacing_m = _positive(spacing_m, "spacing_m")
    thickness_m = _positive(thickness_m, "thickness_m")
    x_m, height_m, x_front_m = _deposit_profile(node_xy_m, spacing_m)
    below = np.flatnonzero(height_m < thickness_m)
    if below.size == 0:
        return x_front_m
    i = int(below[0])
    if i == 0:
        return math.nan
    x0, x1, h0, h1 = x_m[i - 1], x_m[i], height_m[i - 1], height_m[i]
    return float(x0 + (h0 - thickness_m) / (h0 - h1) * (x1 - x0))


def surface_rms_error(node_xy_m, spacing_m: float, reference_xy_m=GRANULAR_SURFACE_XY_M) -> float:
    """RMS height error of the final surface against reference points (x_r, y_r).

    sqrt(mean((H(x_r) - y_r)^2)) over every reference point, with H the deposit profile
    linearly interpolated at x_r (the height of the first profile point before it, 0 beyond
    the deposit's front).
    """
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    spacing_m = _positive(spacing_m, "spacing_m")
    reference_xy_m = _xy(reference_xy_m, "reference_xy_m")
    error_m = _deposit_height(node_xy_m, spacing_m, reference_xy_m[:, 0]) - reference_xy_m[:, 1]
    return float(np.sqrt(np.mean(error_m**2)))


def surface_slope_deg(node_xy_m, spacing_m: float, x_range_m=(0.02, 0.20)) -> float:
    """Mean surface slope: atan(-s) in deg, s the least-squares slope dy/dx of the deposit's
    envelope points with x in ``x_range_m`` (positive for a surface falling away from the wall).
    NaN with fewer than two points in the range."""
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    spacing_m = _positive(spacing_m, "spacing_m")
    deposit_xy_m = _main_deposit(node_xy_m, spacing_m)
    _, top = upper_envelope(deposit_xy_m, spacing_m)
    x_m, y_m = deposit_xy_m[top, 0], deposit_xy_m[top, 1]
    inside = (x_m >= x_range_m[0]) & (x_m <= x_range_m[1])
    if np.count_nonzero(inside) < 2:
        return math.nan
    slope = np.polyfit(x_m[inside], y_m[inside], 1)[0]
    return float(np.degrees(np.arctan(-slope)))


# --------------------------------------------------------------------------------------
# failure line
# --------------------------------------------------------------------------------------


class FailureLine(NamedTuple):
    """Straight failure line x = base_x_m + y / tan(angle_deg) fitted to ``boundary_xy_m``."""

    angle_deg: float
    """Angle from horizontal, atan2(1, -b) for x = a + b y: in (0, 90) for a line rising towards the wall."""
    base_x_m: float
    """Intercept with the base, x at y = 0."""
    boundary_xy_m: np.ndarray
    """(m, 2) boundary points between moved and unmoved material, initial configuration, by row."""


def _moved_particles(node_initial_xy_m, node_displacement_m, threshold_m, spacing_m):
    """Checked (initial positions, mask |u| > threshold, spacing h: given or estimated)."""
    node_initial_xy_m = _xy(node_initial_xy_m, "node_initial_xy_m")
    node_displacement_m = _xy(node_displacement_m, "node_displacement_m")
    if node_displacement_m.shape != node_initial_xy_m.shape:
        raise ValueError("node_displacement_m: must have the shape of node_initial_xy_m")
    threshold_m = _positive(threshold_m, "threshold_m")
    spacing_m = estimate_spacing_m(node_initial_xy_m) if spacing_m is None else _positive(spacing_m, "spacing_m")
    moved = np.hypot(node_displacement_m[:, 0], node_displacement_m[:, 1]) > threshold_m
    return node_initial_xy_m, moved, spacing_m


def failure_line(
    node_initial_xy_m, node_displacement_m, threshold_m: float, spacing_m: float | None = None
) -> FailureLine:
    """Boundary between material that moved (|u| > ``threshold_m``) and material that did not,
    in the INITIAL configuration, and the straight line fitted to it.

    Rows of height h (``spacing_m``; default the median nearest-neighbour distance of the
    initial cloud) centred at y = k h.  In each row the first moved particle is the one with
    the smallest initial x among those with |u| > threshold; the boundary point is the
    midpoint between it and the unmoved particle of the row nearest to it on its left.  Rows
    with no moved particle, or with no unmoved particle left of the first moved one, give no
    point.  x = a + b y is fitted by least squares to the boundary points; angle_deg =
    atan2(1, -b) in deg from horizontal (positive for a line rising towards the wall),
    base_x_m = a.  Both NaN with fewer than two boundary rows.
    """
    node_initial_xy_m, moved, spacing_m = _moved_particles(node_initial_xy_m, node_displacement_m, threshold_m, spacing_m)

    row = _bin_index(node_initial_xy_m[:, 1], spacing_m)
    points = []
    for k in np.unique(row[moved]):
        in_row = row == k
        row_moved = in_row & moved
        first = np.flatnonzero(row_moved)[np.argmin(node_initial_xy_m[row_moved, 0])]
        x_first = node_initial_xy_m[first, 0]
        left = np.flatnonzero(in_row & ~moved & (node_initial_xy_m[:, 0] < x_first))
        if left.size == 0:
            continue
        nearest = left[np.argmax(node_initial_xy_m[left, 0])]
        points.append(0.5 * (node_initial_xy_m[first] + node_initial_xy_m[nearest]))
    boundary_xy_m = np.array(points, dtype=np.float64).reshape(-1, 2)
    if boundary_xy_m.shape[0] < 2 or np.ptp(boundary_xy_m[:, 1]) == 0.0:
        return FailureLine(math.nan, math.nan, boundary_xy_m)
    b, a = np.polyfit(boundary_xy_m[:, 1], boundary_xy_m[:, 0], 1)
    return FailureLine(float(np.degrees(np.arctan2(1.0, -b))), float(a), boundary_xy_m)


# --------------------------------------------------------------------------------------
# cohesive-column metrics
# --------------------------------------------------------------------------------------


def back_scarp_x(
    node_initial_xy_m, node_displacement_m, top_y_m: float, threshold_m: float, spacing_m: float | None = None
) -> float:
    """Back scarp of the failed block, initial configuration: the smallest initial x among the
    particles initially near the top (y >= ``top_y_m`` - 1.5 h) that moved more than
    ``threshold_m`` (|u| > threshold).  h = ``spacing_m``, by default the median
    nearest-neighbour distance of the initial cloud.  NaN if no top particle moved.
    """
    node_initial_xy_m, moved, spacing_m = _moved_particles(node_initial_xy_m, node_displacement_m, threshold_m, spacing_m)
    near_top = node_initial_xy_m[:, 1] >= float(top_y_m) - 1.5 * spacing_m
    selected = near_top & moved
    return float(node_initial_xy_m[selected, 0].min()) if selected.any() else math.nan


def crest_height(node_xy_m, spacing_m: float) -> float:
    """Crest height: the surface height at the wall, :func:`wall_height`."""
    return wall_height(node_xy_m, spacing_m)


def toe_position(node_xy_m, spacing_m: float, n_spacings: float = 2.0) -> float:
    """Toe position: the :func:`runout` at a thickness of ``n_spacings`` spacings."""
    return runout(node_xy_m, spacing_m, n_spacings * _positive(spacing_m, "spacing_m"))


def plastic_zone_area(node_area_m2, node_plastic_strain, threshold: float) -> float:
    """Plastic-zone area: the sum of the cell areas of the particles whose equivalent plastic
    strain exceeds ``threshold`` (strictly)."""
    node_area_m2 = np.asarray(node_area_m2, dtype=np.float64)
    node_plastic_strain = np.asarray(node_plastic_strain, dtype=np.float64)
    if node_area_m2.shape != node_plastic_strain.shape or node_area_m2.ndim != 1:
        raise ValueError("node_area_m2, node_plastic_strain: must be 1-D arrays of equal length")
    return float(node_area_m2[node_plastic_strain > threshold].sum())


# --------------------------------------------------------------------------------------
# summaries (named scalars, units in the keys)
# --------------------------------------------------------------------------------------


def runout_key(thickness_m: float) -> str:
    """Summary key of a runout at ``thickness_m``: 0.002 -> 'runout_2mm_m'."""
    return f"runout_{1000.0 * thickness_m:g}mm_m"


def granular_summary(
    node_xy_m,
    node_initial_xy_m,
    spacing_m: float,
    *,
    reference_surface_xy_m=GRANULAR_SURFACE_XY_M,
    runout_thicknesses_m=(0.002, 0.005, 0.010),
    moved_threshold_m: float = 0.002,
    slope_x_range_m=(0.02, 0.20),
) -> dict[str, float]:
    """Scalars of a granular collapse, keys with units.

    final_wall_height_m (:func:`wall_height`), runout_<t>mm_m per thickness t
    (:func:`runout`), surface_rms_error_m against ``reference_surface_xy_m``
    (:func:`surface_rms_error`), surface_slope_deg over ``slope_x_range_m``
    (:func:`surface_slope_deg`), failure_line_angle_deg and failure_line_base_x_m
    (:func:`failure_line` with displacement = final - initial position and
    ``moved_threshold_m``, rows of ``spacing_m``), and the threshold itself as
    moved_threshold_m.
    """
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    node_initial_xy_m = _xy(node_initial_xy_m, "node_initial_xy_m")
    line = failure_line(node_initial_xy_m, node_xy_m - node_initial_xy_m, moved_threshold_m, spacing_m)
    summary = {"final_wall_height_m": wall_height(node_xy_m, spacing_m)}
    for thickness_m in runout_thicknesses_m:
        summary[runout_key(thickness_m)] = runout(node_xy_m, spacing_m, thickness_m)
    summary["surface_rms_error_m"] = surface_rms_error(node_xy_m, spacing_m, reference_surface_xy_m)
    summary["surface_slope_deg"] = surface_slope_deg(node_xy_m, spacing_m, slope_x_range_m)
    summary["failure_line_angle_deg"] = line.angle_deg
    summary["failure_line_base_x_m"] = line.base_x_m
    summary["moved_threshold_m"] = float(moved_threshold_m)
    return summary


def cohesive_summary(
    node_xy_m,
    node_initial_xy_m,
    spacing_m: float,
    node_area_m2,
    node_plastic_strain,
    *,
    top_y_m: float | None = None,
    moved_threshold_m: float = 0.05,
    plastic_strain_threshold: float = 0.01,
    toe_n_spacings: float = 2.0,
) -> dict[str, float]:
    """Scalars of a cohesive collapse, keys with units.

    back_scarp_x_m (:func:`back_scarp_x`, top_y_m default the largest initial y,
    displacement = final - initial position), crest_height_m (:func:`crest_height`),
    toe_x_m (:func:`toe_position` at ``toe_n_spacings`` spacings), plastic_zone_area_m2
    (:func:`plastic_zone_area`), and the thresholds used: moved_threshold_m,
    plastic_strain_threshold, toe_thickness_m.
    """
    node_xy_m = _xy(node_xy_m, "node_xy_m")
    node_initial_xy_m = _xy(node_initial_xy_m, "node_initial_xy_m")
    if top_y_m is None:
        top_y_m = float(node_initial_xy_m[:, 1].max())
    node_displacement_m = node_xy_m - node_initial_xy_m
    return {
        "back_scarp_x_m": back_scarp_x(node_initial_xy_m, node_displacement_m, top_y_m, moved_threshold_m, spacing_m),
        "crest_height_m": crest_height(node_xy_m, spacing_m),
        "toe_x_m": toe_position(node_xy_m, spacing_m, toe_n_spacings),
        "plastic_zone_area_m2": plastic_zone_area(node_area_m2, node_plastic_strain, plastic_strain_threshold),
        "moved_threshold_m": float(moved_threshold_m),
        "plastic_strain_threshold": float(plastic_strain_threshold),
        "toe_thickness_m": float(toe_n_spacings * spacing_m),
    }
