"""Collapse metrics on synthetic particle clouds with known answers, and the reference data."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spfem_core.cloud import particles_in_polygon
from verification import collapse_references as ref
from workflows.collapse import experiment
from workflows.collapse import metrics as cm

H_GRANULAR = 0.002

# A known deposit: wall at x = 0, piecewise-linear free surface, vertical front at x = 0.46.
SURFACE_XY_M = np.array([[0.0, 0.1], [0.05, 0.095], [0.25, 0.03], [0.40, 0.006], [0.46, 0.003]])


def cloud_under_surface(surface_xy_m, spacing_m, jitter=0.0):
    """Particles filling the region between the base, the wall, the surface polyline and a
    vertical front at its last x (surface particles lie on the surface)."""
    s = np.asarray(surface_xy_m, dtype=float)
    polygon = np.r_[[[s[0, 0], 0.0]], s, [[s[-1, 0], 0.0]]]
    return particles_in_polygon(polygon, spacing_m, jitter=jitter)


def first_crossing(surface_xy_m, thickness_m):
    """Exact runout of a polyline surface with a vertical front: first x where y < t."""
    s = np.asarray(surface_xy_m, dtype=float)
    for (x0, y0), (x1, y1) in zip(s[:-1], s[1:]):
        if y1 < thickness_m <= y0:
            return x0 + (y0 - thickness_m) / (y0 - y1) * (x1 - x0)
    return s[-1, 0]


def experimental_cloud(spacing_m):
    s = experiment.GRANULAR_SURFACE_XY_M
    surface = np.r_[[[0.0, s[0, 1]]], s[1:]]  # the first point is 0.12 mm off the wall: put it on the wall
    return cloud_under_surface(surface, spacing_m)


# --------------------------------------------------------------------------------------
# reference data
# --------------------------------------------------------------------------------------


def test_reference_tables():
    surface = experiment.GRANULAR_SURFACE_XY_M
    assert surface.shape == (23, 2)  # the table of collapse_refs.md holds 23 points
    assert np.all(np.diff(surface[:, 0]) > 0.0)
    assert experiment.GRANULAR_FAILURE_LINE_XY_M.shape == (9, 2)
    # the straight line through the digitised failure line is the one collapse_refs.md states
    b, a = np.polyfit(experiment.GRANULAR_FAILURE_LINE_XY_M[:, 1], experiment.GRANULAR_FAILURE_LINE_XY_M[:, 0], 1)
    assert math.degrees(math.atan2(1.0, -b)) == pytest.approx(33.0, abs=0.5)
    assert a == pytest.approx(0.179, abs=0.001)
    # the metrics derived from the experiment sit inside the pass bands built around them
    bands = ref.GRANULAR_PASS_BANDS.bands()
    derived = {
        "final_wall_height_m": ref.GRANULAR_WALL_HEIGHT_M,
        "runout_2mm_m": ref.GRANULAR_RUNOUT_BY_THICKNESS_M[0.002],
        "failure_line_angle_deg": ref.GRANULAR_FAILURE_LINE_ANGLE_DEG,
        "failure_line_base_x_m": ref.GRANULAR_FAILURE_LINE_BASE_X_M,
    }
    for key, value in derived.items():
        low, high = bands[key]
        assert low <= value <= high, key


def test_pass_bands_report_failures():
    failures = ref.GRANULAR_PASS_BANDS.failures({"final_wall_height_m": 0.09, "runout_2mm_m": math.nan})
    assert len(failures) == 5  # two out of band, three missing
    assert failures[0].startswith("final_wall_height_m")


def test_cohesive_closed_forms_match_collapse_refs():
    gamma = ref.COHESIVE_DENSITY_KG_M3 * ref.COHESIVE_GRAVITY_M_S2
    c, phi = ref.COHESIVE_COHESION_PA, ref.COHESIVE_FRICTION_ANGLE_DEG
    assert ref.critical_cut_height_m(c, phi, gamma) == pytest.approx(1.73, abs=0.005)
    # 0.865 m: collapse_refs.md rounds half of 1.73 up to 0.87
    assert ref.tension_crack_depth_m(c, phi, gamma) == pytest.approx(0.87, abs=0.006)
    assert ref.culmann_angle_deg(phi) == 57.5
    x_top = ref.culmann_top_x_m(phi, ref.COHESIVE_COLUMN_HEIGHT_M, ref.COHESIVE_COLUMN_WIDTH_M)
    assert x_top == pytest.approx(2.73, abs=0.005)
    low, high = ref.COHESIVE_BACK_SCARP_BAND_M
    assert low <= x_top <= high
    assert ref.passive_coefficient(0.0) == pytest.approx(1.0)
    assert ref.passive_coefficient(30.0) == pytest.approx(3.0)


# --------------------------------------------------------------------------------------
# surface profile, wall height, runout, RMS error
# --------------------------------------------------------------------------------------


def test_surface_profile_is_the_upper_envelope():
    h = H_GRANULAR
    xy = cloud_under_surface(SURFACE_XY_M, h)
    x, height = cm.surface_profile(xy, h)
    assert np.all(np.diff(x) > 0.0)
    assert x.size == round(0.46 / h) + 1  # bins centred at k h from the wall to the front
    # every bin is occupied and its point is a surface particle
    np.testing.assert_allclose(height, np.interp(x, SURFACE_XY_M[:, 0], SURFACE_XY_M[:, 1]), atol=1e-12)
    # interpolated onto a grid: within a fraction of h of the surface (chords cut the kinks)
    grid = np.linspace(0.0, 0.46, 1000)
    x_grid, h_grid = cm.surface_profile(xy, h, x_grid_m=grid)
    np.testing.assert_array_equal(x_grid, grid)
    assert np.max(np.abs(h_grid - np.interp(grid, *SURFACE_XY_M.T))) < 0.1 * h
    # past the last bin the height is 0
    assert cm.surface_profile(xy, h, x_grid_m=[0.5])[1][0] == 0.0


def test_surface_profile_empty_bins_have_zero_height():
    h = 0.01
    xy = np.array([[0.0, 0.0], [0.0, 0.05], [0.05, 0.02], [0.052, 0.03]])
    x, height = cm.surface_profile(xy, h)
    np.testing.assert_allclose(x, [0.0, 0.01, 0.02, 0.03, 0.04, 0.052])
    np.testing.assert_allclose(height, [0.05, 0, 0, 0, 0, 0.03])


def test_wall_height():
    h = H_GRANULAR
    xy = cloud_under_surface(SURFACE_XY_M, h)
    assert cm.wall_height(xy, h) == 0.1
    assert cm.crest_height(xy, h) == 0.1
    rising = np.array([[0.0, 0.05], [0.1, 0.06], [0.2, 0.01]])
    # surface rising from the wall: the height of the last surface particle with x < h
    assert 0.05 < cm.wall_height(cloud_under_surface(rising, h), h) < 0.05 + 0.1 * h
    assert cm.wall_height(np.array([[0.5, 1.0]]), h) == 0.0


@pytest.mark.parametrize("h", [0.002, 0.004, 0.001])
@pytest.mark.parametrize("thickness", [0.002, 0.005, 0.01, 0.05, 0.097])
def test_runout_at_several_thresholds(h, thickness):
    xy = cloud_under_surface(SURFACE_XY_M, h, jitter=0.2)
    assert cm.runout(xy, h, thickness) == pytest.approx(first_crossing(SURFACE_XY_M, thickness), abs=h)


def test_runout_below_threshold_at_the_wall_is_nan():
    h = H_GRANULAR
    assert math.isnan(cm.runout(cloud_under_surface(SURFACE_XY_M, h), h, 0.2))


def test_runout_takes_the_first_crossing_from_the_wall():
    # the surface dips to 4 mm at x = 0.2 and rises to 20 mm again before the front
    surface = np.array([[0.0, 0.05], [0.2, 0.004], [0.3, 0.02], [0.35, 0.02]])
    h = H_GRANULAR
    xy = cloud_under_surface(surface, h)
    assert cm.runout(xy, h, 0.01) == pytest.approx(first_crossing(surface, 0.01), abs=h)
    assert cm.runout(xy, h, 0.003) == pytest.approx(0.35, abs=h)


def test_runout_ignores_isolated_particles_and_bridges_small_gaps():
    h = H_GRANULAR
    xy = cloud_under_surface(SURFACE_XY_M, h)
    expected = {t: cm.runout(xy, h, t) for t in (0.002, 0.005, 0.01)}
    # an isolated particle more than 2 spacings beyond the front
    far = np.r_[xy, [[0.46 + 2.5 * h, 0.02]]]
    for t, value in expected.items():
        assert cm.runout(far, h, t) == value
    assert cm.surface_rms_error(far, h, SURFACE_XY_M) == cm.surface_rms_error(xy, h, SURFACE_XY_M)
    # ... but surface_profile shows it, with empty bins at 0 between
    x, height = cm.surface_profile(far, h)
    assert height[-1] == 0.02 and np.all(height[-3:-1] == 0.0)
    # a particle within 2 spacings belongs to the deposit: it moves the front
    near = np.r_[xy, [[0.46 + 1.5 * h, 0.0]]]
    assert cm.runout(near, h, 0.002) == pytest.approx(0.46, abs=h)
    # a missing column of particles inside the deposit is bridged
    x_column = 0.30
    holed = xy[np.abs(xy[:, 0] - x_column) > 0.6 * h]
    assert cm.runout(holed, h, 0.005) == pytest.approx(expected[0.005], abs=h)
    assert cm.runout(holed, h, 0.01) == pytest.approx(expected[0.01], abs=h)


def test_surface_rms_error():
    h = H_GRANULAR
    xy = cloud_under_surface(SURFACE_XY_M, h)
    reference = np.c_[np.linspace(0.0, 0.46, 60), np.interp(np.linspace(0.0, 0.46, 60), *SURFACE_XY_M.T)]
    assert cm.surface_rms_error(xy, h, reference) < 0.05 * h
    assert cm.surface_rms_error(xy, h, SURFACE_XY_M) == pytest.approx(0.0, abs=1e-12)
    offset = 0.003
    assert cm.surface_rms_error(xy, h, reference + [0.0, offset]) == pytest.approx(offset, rel=0.02)
    # a reference point beyond the deposit counts with zero simulated height
    beyond = np.array([[0.6, 0.004]])
    assert cm.surface_rms_error(xy, h, beyond) == pytest.approx(0.004)
    both = np.r_[SURFACE_XY_M, beyond]
    assert cm.surface_rms_error(xy, h, both) == pytest.approx(math.sqrt(0.004**2 / both.shape[0]), rel=1e-9)


@settings(deadline=None, max_examples=30)
@given(
    drops=st.lists(st.floats(0.05, 1.0), min_size=2, max_size=5),
    lengths=st.lists(st.floats(0.03, 0.2), min_size=5, max_size=5),
    fraction=st.floats(0.02, 0.98),
    h=st.sampled_from([0.002, 0.003, 0.005]),
)
def test_runout_property_random_surfaces(drops, lengths, fraction, h):
    """For any falling piecewise-linear surface (slopes 0.05-1), the runout is within one spacing."""
    x = np.r_[0.0, np.cumsum(lengths[: len(drops)])]
    y = 0.2 - np.r_[0.0, np.cumsum(np.array(drops) * np.diff(x))]
    if y[-1] < 2 * h:
        y = y - y[-1] + 2 * h
    surface = np.c_[x, y]
    thickness = y[-1] + fraction * (y[0] - y[-1])
    xy = cloud_under_surface(surface, h)
    assert cm.runout(xy, h, thickness) == pytest.approx(first_crossing(surface, thickness), abs=h)


# --------------------------------------------------------------------------------------
# the experimental deposit reproduces the derived metrics of collapse_refs.md
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("h", [0.002, 0.001])
def test_experimental_surface_reproduces_derived_metrics(h):
    xy = experimental_cloud(h)
    assert cm.wall_height(xy, h) == pytest.approx(ref.GRANULAR_WALL_HEIGHT_M, abs=h)
    for thickness, expected in ref.GRANULAR_RUNOUT_BY_THICKNESS_M.items():
        assert cm.runout(xy, h, thickness) == pytest.approx(expected, abs=h)
    assert cm.surface_rms_error(xy, h, experiment.GRANULAR_SURFACE_XY_M) < 0.1 * h
    assert cm.surface_slope_deg(xy, h) == pytest.approx(ref.GRANULAR_SURFACE_SLOPE_DEG, abs=1.0)


# --------------------------------------------------------------------------------------
# failure line
# --------------------------------------------------------------------------------------


def displaced_block(initial_xy, moved, seed=0, threshold=0.001):
    """Moved particles get |u| in (2, 20) thresholds, the rest |u| below half a threshold."""
    rng = np.random.default_rng(seed)
    n = initial_xy.shape[0]
    direction = rng.normal(size=(n, 2))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    magnitude = np.where(moved, rng.uniform(2.0, 20.0, n), rng.uniform(0.0, 0.5, n)) * threshold
    return direction * magnitude[:, None]


@pytest.mark.parametrize("jitter", [0.0, 0.25])
@pytest.mark.parametrize("angle_deg, base_x", [(33.0, 0.18), (45.0, 0.15), (60.0, 0.19)])
def test_failure_line_recovers_a_straight_line(jitter, angle_deg, base_x):
    h = H_GRANULAR
    initial = particles_in_polygon([[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]], h, jitter=jitter)
    moved = initial[:, 0] > base_x - initial[:, 1] / math.tan(math.radians(angle_deg))
    u = displaced_block(initial, moved)
    line = cm.failure_line(initial, u, 0.001, h)
    assert line.angle_deg == pytest.approx(angle_deg, abs=1.0)
    assert line.base_x_m == pytest.approx(base_x, abs=h)
    assert line.boundary_xy_m.shape[1] == 2 and line.boundary_xy_m.shape[0] > 40
    # the default row height is the nearest-neighbour spacing
    default = cm.failure_line(initial, u, 0.001)
    assert default.angle_deg == pytest.approx(angle_deg, abs=1.0)


def test_failure_line_sign_convention_and_whole_rows():
    h = H_GRANULAR
    initial = particles_in_polygon([[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]], h)
    # a line rising away from the wall: x = 0.05 + 0.5 y -> atan2(1, -0.5)
    away = initial[:, 0] > 0.05 + 0.5 * initial[:, 1]
    line = cm.failure_line(initial, displaced_block(initial, away), 0.001, h)
    assert line.angle_deg == pytest.approx(math.degrees(math.atan2(1.0, -0.5)), abs=1.0)
    assert line.base_x_m == pytest.approx(0.05, abs=h)
    # rows that moved entirely (no boundary inside the column) are ignored
    moved = (initial[:, 0] > 0.18 - initial[:, 1] / math.tan(math.radians(33.0))) | (initial[:, 1] > 0.08)
    line = cm.failure_line(initial, displaced_block(initial, moved), 0.001, h)
    assert line.angle_deg == pytest.approx(33.0, abs=1.0)
    assert line.boundary_xy_m[:, 1].max() < 0.08 + h
    # nothing moved: no line
    nothing = cm.failure_line(initial, np.zeros_like(initial), 0.001, h)
    assert math.isnan(nothing.angle_deg) and nothing.boundary_xy_m.shape == (0, 2)


def test_failure_line_of_the_experiment():
    """Particles right of the digitised failure line moved: the fit gives the stated line."""
    h = H_GRANULAR
    initial = particles_in_polygon([[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]], h)
    line_xy = experiment.GRANULAR_FAILURE_LINE_XY_M[::-1]  # by increasing y
    moved = initial[:, 0] > np.interp(initial[:, 1], line_xy[:, 1], line_xy[:, 0])
    line = cm.failure_line(initial, displaced_block(initial, moved), 0.001, h)
    assert line.angle_deg == pytest.approx(ref.GRANULAR_FAILURE_LINE_ANGLE_DEG, abs=1.0)
    assert line.base_x_m == pytest.approx(ref.GRANULAR_FAILURE_LINE_BASE_X_M, abs=h)


# --------------------------------------------------------------------------------------
# cohesive metrics
# --------------------------------------------------------------------------------------


def test_back_scarp_at_the_culmann_plane():
    h = 0.04
    initial = particles_in_polygon([[0, 0], [4, 0], [4, 2], [0, 2]], h)
    phi = ref.COHESIVE_FRICTION_ANGLE_DEG
    x_plane = 4.0 - initial[:, 1] / math.tan(math.radians(ref.culmann_angle_deg(phi)))
    moved = initial[:, 0] > x_plane
    u = displaced_block(initial, moved, threshold=0.05)
    expected = ref.culmann_top_x_m(phi, 2.0, 4.0)
    assert cm.back_scarp_x(initial, u, 2.0, 0.05, h) == pytest.approx(expected, abs=h)
    assert cm.back_scarp_x(initial, u, 2.0, 0.05) == pytest.approx(expected, abs=h)
    # only particles near the top count: a deep moved particle further left is ignored
    u_deep = u.copy()
    u_deep[np.argmin(np.hypot(initial[:, 0] - 1.0, initial[:, 1] - 1.0))] = [1.0, 0.0]
    assert cm.back_scarp_x(initial, u_deep, 2.0, 0.05, h) == pytest.approx(expected, abs=h)
    assert math.isnan(cm.back_scarp_x(initial, np.zeros_like(initial), 2.0, 0.05, h))


def test_plastic_zone_area():
    h = 0.05
    i, j = np.meshgrid(np.arange(80), np.arange(40), indexing="ij")
    xy = np.c_[i.ravel() * h + h / 2, j.ravel() * h + h / 2]
    area = np.full(xy.shape[0], h * h)
    strain = np.where((xy[:, 0] < 1.0) & (xy[:, 1] < 0.5), 0.3, 0.001)
    assert cm.plastic_zone_area(area, strain, 0.01) == pytest.approx(0.5)
    assert cm.plastic_zone_area(area, strain, 0.3) == 0.0  # strictly above the threshold
    assert cm.plastic_zone_area(area, strain, 0.0) == pytest.approx(8.0)
    with pytest.raises(ValueError):
        cm.plastic_zone_area(area, strain[:-1], 0.01)


def test_toe_position_is_the_runout_at_two_spacings():
    h = 0.04
    surface = np.array([[0.0, 1.2], [1.0, 1.0], [3.0, 0.3], [5.5, 0.02]])
    xy = cloud_under_surface(surface, h)
    assert cm.toe_position(xy, h) == cm.runout(xy, h, 2 * h)
    assert cm.toe_position(xy, h) == pytest.approx(first_crossing(surface, 2 * h), abs=h)


# --------------------------------------------------------------------------------------
# summaries
# --------------------------------------------------------------------------------------


def test_granular_summary_on_the_experiment():
    """Final cloud = the experimental deposit; material right of the stated failure line
    (33 deg, base at 0.179 m) moved parallel to it, so the boundary stays put in the
    initial configuration."""
    h = H_GRANULAR
    final = experimental_cloud(h)
    angle = math.radians(ref.GRANULAR_FAILURE_LINE_ANGLE_DEG)
    moved = final[:, 0] > ref.GRANULAR_FAILURE_LINE_BASE_X_M - final[:, 1] / math.tan(angle)
    initial = final - moved[:, None] * 0.02 * np.array([math.cos(angle), -math.sin(angle)])
    summary = cm.granular_summary(final, initial, h)
    assert set(summary) == {
        "final_wall_height_m",
        "runout_2mm_m",
        "runout_5mm_m",
        "runout_10mm_m",
        "surface_rms_error_m",
        "surface_slope_deg",
        "failure_line_angle_deg",
        "failure_line_base_x_m",
        "moved_threshold_m",
    }
    assert all(isinstance(value, float) for value in summary.values())
    assert summary["runout_2mm_m"] == cm.runout(final, h, 0.002)
    assert summary["final_wall_height_m"] == pytest.approx(ref.GRANULAR_WALL_HEIGHT_M, abs=h)
    assert summary["failure_line_angle_deg"] == pytest.approx(33.0, abs=1.0)
    assert summary["failure_line_base_x_m"] == pytest.approx(0.179, abs=h)
    assert ref.GRANULAR_PASS_BANDS.failures(summary) == []


def test_cohesive_summary():
    h = 0.04
    initial = particles_in_polygon([[0, 0], [4, 0], [4, 2], [0, 2]], h)
    phi = ref.COHESIVE_FRICTION_ANGLE_DEG
    moved = initial[:, 0] > 4.0 - initial[:, 1] / math.tan(math.radians(ref.culmann_angle_deg(phi)))
    final = initial + moved[:, None] * np.array([0.6, -0.4])
    area = np.full(initial.shape[0], h * h)
    strain = np.where(moved, 0.5, 0.0)
    summary = cm.cohesive_summary(final, initial, h, area, strain)
    assert summary == {
        "back_scarp_x_m": cm.back_scarp_x(initial, final - initial, 2.0, 0.05, h),
        "crest_height_m": cm.crest_height(final, h),
        "toe_x_m": cm.toe_position(final, h, 2),
        "plastic_zone_area_m2": cm.plastic_zone_area(area, strain, 0.01),
        "moved_threshold_m": 0.05,
        "plastic_strain_threshold": 0.01,
        "toe_thickness_m": 2 * h,
    }
    assert summary["back_scarp_x_m"] == pytest.approx(ref.culmann_top_x_m(phi, 2.0, 4.0), abs=h)
    assert summary["crest_height_m"] == pytest.approx(2.0)
    assert summary["toe_x_m"] == pytest.approx(4.6, abs=h)


def test_input_validation():
    with pytest.raises(ValueError):
        cm.surface_profile(np.zeros((0, 2)), 0.01)
    with pytest.raises(ValueError):
        cm.runout(np.zeros((3, 3)), 0.01, 0.002)
    with pytest.raises(ValueError):
        cm.wall_height(np.zeros((3, 2)), 0.0)
    with pytest.raises(ValueError):
        cm.failure_line(np.zeros((3, 2)), np.zeros((2, 2)), 0.001, 0.01)
