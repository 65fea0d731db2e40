"""The slip surface (workflows.fos.slip_surface): a known mechanism is found where it is, its
limit-equilibrium FOS is the one on the true line, and a real study stores and draws it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from spfem_core.geometry import points_in_polygon, surface_height_m
from workflows.fos import slip_surface as slip
from workflows.fos.limit_equilibrium import spencer
from workflows.study import load_study

REPO = Path(__file__).resolve().parents[1]
CENTRE_M, RADIUS_M = (np.array([31.0, 24.0]), 19.6)  # a toe circle of the reference slope


@pytest.fixture(scope="module")
def reference():
    """The quickstart's slope (10 m high at 1V:2H, c = 10 kPa, phi = 20 deg) on a 0.25 m lattice,
    the mass inside a circle turned rigidly about its centre by 1 mrad, the rest moved by 1e-5 m
    of noise: particle fields as a run file holds them."""
    study = load_study(REPO / "studies" / "quickstart.toml")
    h = 0.25
    x, y = np.meshgrid(np.arange(0.0, 60.0 + h / 2, h), np.arange(0.0, 15.0 + h / 2, h))
    xy = np.column_stack([x.ravel(), y.ravel()])
    xy = xy[points_in_polygon(xy, np.array(study.geometry.polygon_m), 1e-9)]
    inside = np.hypot(*(xy - CENTRE_M).T) < RADIUS_M
    rng = np.random.default_rng(0)
    ux, uy = rng.normal(0.0, 1e-5, (2, xy.shape[0]))
    turn = 1e-3  # clockwise about the centre: the mass slides down to the right
    ux[inside] += turn * (xy[inside, 1] - CENTRE_M[1])
    uy[inside] -= turn * (xy[inside, 0] - CENTRE_M[0])
    n = xy.shape[0]
    particles = {"x0": xy[:, 0], "y0": xy[:, 1], "ux": ux, "uy": uy, "mass": np.full(n, 2000.0 * h * h),
                 "spacing": np.full(n, h), "material": np.zeros(n, dtype=np.int64), "pore_pressure": np.zeros(n)}
    return study, particles, inside, h


def _circle_line(study, n=400):
    """The true slip circle between its two crossings of the ground, from the crest side."""
    x = np.linspace(0.0, 60.0, 20001)
    below = CENTRE_M[1] - np.sqrt(np.maximum(RADIUS_M**2 - (x - CENTRE_M[0]) ** 2, 0.0))
    cut = x[below < surface_height_m(study.geometry.polygon_m, x)]
    xs = np.linspace(cut.min(), cut.max(), n)
    return xs, CENTRE_M[1] - np.sqrt(RADIUS_M**2 - (xs - CENTRE_M[0]) ** 2)


def test_the_mechanism_is_the_rotating_mass(reference):
    study, particles, inside, h = reference
    xy = np.column_stack([particles["x0"], particles["y0"]])
    mass, typical_m = slip.moving_mass(xy, np.hypot(particles["ux"], particles["uy"]), h)
    assert np.count_nonzero(mass != inside) < 0.05 * inside.sum()
    assert 1e-3 * 9.0 < typical_m < 1e-3 * RADIUS_M  # turn x distance from the centre


def test_the_line_follows_the_circle(reference):
    study, particles, _, h = reference
    surface = slip.slip_surface(study, particles, None, 1.5, np.nan)
    circle_x, circle_y = _circle_line(study)
    inner = (surface.x_m > circle_x.min() + 2 * h) & (surface.x_m < circle_x.max() - 2 * h)
    assert np.max(np.abs(surface.y_m[inner] - np.interp(surface.x_m[inner], circle_x, circle_y))) < h
    assert surface.entry_m[0] == pytest.approx(circle_x.min(), abs=2 * h) and surface.entry_m[1] == 15.0
    assert surface.exit_m[0] == pytest.approx(circle_x.max(), abs=2 * h)
    segment_m2 = np.trapezoid(surface_height_m(study.geometry.polygon_m, circle_x) - circle_y, circle_x)
    assert surface.area_m2 == pytest.approx(segment_m2, rel=0.03)
    assert surface.depth_m == pytest.approx(
        np.max(surface_height_m(study.geometry.polygon_m, circle_x) - circle_y), abs=h)


def test_its_limit_equilibrium_fos_is_the_true_lines(reference):
    """Spencer on the extracted line and particle weights against Spencer on the exact circle
    and the exact weights gamma b (ground - base)."""
    study, particles, _, h = reference
    surface = slip.slip_surface(study, particles, None, 1.5, np.nan)
    circle_x, circle_y = _circle_line(study)
    exact = slip.limit_equilibrium_slices(study, particles, circle_x, circle_y)
    top = surface_height_m(study.geometry.polygon_m, exact.x_m)
    exact = type(exact)(**{**exact.__dict__, "vertical_load_n": 2000.0 * 10.0 * exact.width_m * (top - exact.y_m)})
    assert surface.limit_equilibrium.fos == pytest.approx(spencer(exact).fos, rel=0.02)


def test_a_mass_moving_left_is_mirrored(reference):
    """The same slope and mechanism mirrored in x: the same line, mirrored, and the same FOS."""
    study, particles, _, h = reference
    import dataclasses

    polygon = [(60.0 - x, y) for x, y in study.geometry.polygon_m][::-1]
    mirrored_study = dataclasses.replace(study, monitors=(),
                                         geometry=dataclasses.replace(study.geometry, polygon_m=tuple(polygon)))
    mirrored = {**particles, "x0": 60.0 - particles["x0"], "ux": -particles["ux"]}
    right = slip.slip_surface(study, particles, None, 1.5, np.nan)
    left = slip.slip_surface(mirrored_study, mirrored, None, 1.5, np.nan)
    np.testing.assert_allclose(60.0 - left.x_m, right.x_m, atol=1e-9)
    assert left.limit_equilibrium.fos == pytest.approx(right.limit_equilibrium.fos, rel=1e-9)


def test_the_quickstart_stores_and_draws_its_slip_surface(quickstart_run):
    study, out, outcome = quickstart_run
    summary = xr.load_dataset(out / "summary.nc")
    assert summary["slip_x"].attrs["units"] == "m" and summary.sizes["slip_point"] > 5
    assert float(summary["slip_srf"]) == outcome.status_high
    assert 10.0 < float(summary["slip_entry_x"]) < 20.0 and float(summary["slip_entry_y"]) == 15.0
    assert 36.0 < float(summary["slip_exit_x"]) < 46.0 and float(summary["slip_exit_y"]) == 5.0
    # Spencer on the mechanism's line: no lower than limit equilibrium's critical surface (1.366)
    assert 1.35 < float(summary["le_fos"]) < 1.05 * outcome.fos
    assert summary["le_fos"].attrs["method"] == "Spencer"
    assert (out / "slip_surface.png").is_file()


def test_the_envelope_holds_the_deepest_and_shallowest_line():
    deep = (np.array([0.0, 5.0, 10.0]), np.array([10.0, 2.0, 10.0]))
    shallow = (np.array([4.0, 6.0, 8.0]), np.array([10.0, 8.0, 10.0]))
    x, lower, upper, count = slip.envelope([deep, shallow])
    assert x[0] == 0.0 and x[-1] == 10.0
    middle = np.argmin(np.abs(x - 5.0))
    assert lower[middle] == pytest.approx(np.interp(x[middle], *deep)) and count[middle] == 2
    assert upper[middle] == pytest.approx(np.interp(x[middle], *shallow))
    assert count[0] == 1 and lower[0] == upper[0] == 10.0


def _run_slip(text: str, tmp_path):
    from workflows.cases import RunOptions
    from workflows.study import parse_study
    from workflows.study_types import run_study

    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    return outcome, outcome.slip


def test_a_shallow_face_slide_on_a_steep_slope_is_drawn_where_the_soil_moved(tmp_path):
    """A 1H:1V slope at phi 40 deg at H/10 fails by a face slide through the toe: the line is its band
    (a couple of metres deep, not a deep circle through the displacements' scatter), and Spencer on
    it lies within the cross-check margin of the FOS."""
    from verification.fos_accuracy import c_phi_text

    outcome, surface = _run_slip(c_phi_text("phi40_1h1v"), tmp_path)
    assert surface.depth_m < 4.0 and 15.0 < surface.entry_m[0] < 20.5 and 28.0 < surface.exit_m[0] < 31.0
    assert abs(surface.limit_equilibrium.fos / outcome.fos - 1.0) < slip.CROSS_CHECK_MARGIN


def test_a_refined_zone_over_part_of_the_slope_does_not_bend_the_line_to_its_edge(tmp_path):
    """A zone of 0.5 m particles over the upper half of the quickstart's face: the line is the band
    through both spacings, its entry behind the crest and its exit at the toe as without the zone."""
    zone = ('\n[[geometry.refined]]\nname = "upper"\nspacing_m = 0.5\n'
            "region_m = [[15.0, 8.0], [30.0, 8.0], [30.0, 16.0], [15.0, 16.0]]\n")
    text = (REPO / "studies" / "quickstart.toml").read_text().replace("[[materials]]", zone + "\n[[materials]]", 1)
    outcome, surface = _run_slip(text, tmp_path)
    assert 14.0 < surface.entry_m[0] < 20.0 and 37.0 < surface.exit_m[0] < 43.0
    assert np.all(np.diff(surface.x_m) > 0.0)  # no vertical step at the zone's edge
    assert abs(surface.limit_equilibrium.fos / outcome.fos - 1.0) < slip.CROSS_CHECK_MARGIN
