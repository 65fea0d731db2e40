"""When the box decides: a mechanism that reaches a side of the domain is named after the run
(``workflows.fos.domain_edges``), and ``check`` sees a domain too short for the critical circle of a
limit-equilibrium search before the run (``workflows.fos.critical_circle``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from verification.least_circle import slope_least_circle
from verification.study_text import (
    drained_soil,
    gravity,
    gravity_stage,
    held_base_and_sides,
    slope_form,
    srf_stage,
    study_text,
)
from workflows.cases import RunOptions
from workflows.fos.critical_circle import critical_circle, domain_warnings
from workflows.study import load_study, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]

SHORT_DOMAIN = study_text(
    "short", {"spacing_m": 1.0, "slope": slope_form(10.0, 2.0, foundation_depth_m=10.0, crest_length_m=3.0,
                                                   toe_length_m=3.0)},
    [{"name": "clay", "model": "tresca", "unit_weight_kn_m3": 20.0, "youngs_modulus_mpa": 100.0, "poisson_ratio": 0.45,
      "undrained_shear_strength_kpa": 50.0}],
    [gravity_stage(20.0, 0.05), srf_stage(8.0, 0.02)])
"""An undrained slope on a deep foundation drawn 3 m behind its crest and 3 m beyond its toe: its
deep base circle needs some 10 m more on either side."""


def test_a_mechanism_at_the_sides_of_a_short_domain_is_named_in_the_report_and_summary(tmp_path):
    outcome = run_study(parse_study(SHORT_DOMAIN), tmp_path, RunOptions(workers=2))
    sides = {contact.support for contact in outcome.edges if contact.warning}
    assert "left" in sides
    with xr.open_dataset(tmp_path / "summary.nc") as ds:
        assert ds.attrs["box_decides"] == 1 and "behind the crest" in ds.attrs["mechanism_edges"]
    from workflows.fos.report import report_lines

    assert any(line.startswith("WARNING, the box decides") and "widen" in line for line in report_lines(outcome))


def test_the_quickstarts_mechanism_stays_clear_of_the_box(quickstart_run):
    _, out, outcome = quickstart_run
    assert not [contact for contact in outcome.edges if contact.warning]
    with xr.open_dataset(out / "summary.nc") as ds:
        assert ds.attrs["box_decides"] == 0


NARROW_SLOPE = study_text(
    "narrow", {"polygon_m": [[8.0, 0.0], [20.5, 0.0], [20.5, 3.0], [20.0, 3.0], [10.0, 8.0], [8.0, 8.0]],
               "spacing_m": 1.0},
    [drained_soil()], [gravity_stage(5.0, 0.1), srf_stage(1.0, 0.05, 1.0, 1.4, 0.2)],
    loads=gravity(), boundary=held_base_and_sides(8.0))
"""A coarse slope (h = 1 m) drawn 2 m behind its crest, the fuzzer's seepage slope cut short
(``verification.fuzz_study_files``, check (a))."""


def test_a_back_scarp_at_a_side_reaches_it_however_few_particles_lie_between():
    """A shear band that comes out on the ground one spacing from the side: its slip line enters half a
    spacing from the side, and the one particle of the mechanism next to the side (fewer than
    MIN_CONTACT) must not hide that the box decides."""
    from spfem_core.geometry import distance_to_edges_m
    from workflows.fos.domain_edges import MIN_CONTACT, SIDE, edge_contacts, mechanism_particles
    from workflows.fos.slip_surface import slip_surface
    from workflows.particles import cloud_of_geometry

    study = parse_study(NARROW_SLOPE)
    xy0, spacing = cloud_of_geometry(study.geometry)
    band = np.array([[9.0, 8.0], [12.0, 5.0], [16.0, 3.0], [20.0, 3.0]])  # from the crest's corner to the toe
    n = xy0.shape[0]
    failed = {"x0": xy0[:, 0], "y0": xy0[:, 1], "ux": np.zeros(n), "uy": np.zeros(n), "spacing": spacing,
              "plastic_strain": (distance_to_edges_m(xy0, band, closed=False) <= 0.5).astype(float),
              "mass": np.full(n, 2000.0), "material": np.zeros(n, dtype=np.int64), "pore_pressure": np.zeros(n)}
    slip = slip_surface(study, failed, None, 1.2, math.nan, limit_equilibrium=False)
    assert slip.entry_m[0] == pytest.approx(8.5)  # within one spacing of the side x = 8 m
    members = mechanism_particles(failed, None)
    assert np.count_nonzero(members & (xy0[:, 0] <= 9.5)) < MIN_CONTACT  # the count alone would miss it
    contacts = edge_contacts(study, failed, None, (slip.x_m, slip.y_m))
    assert [(c.support, c.kind, c.warning) for c in contacts] == [("sides", SIDE, True)]


def test_bishops_critical_circle_of_the_reference_slope_is_limit_equilibriums_and_sees_no_short_domain():
    """Bishop on the raster of the section: 1.369 published (Bishop simplified), within 1%."""
    study = load_study(REPO / "studies" / "quickstart.toml")
    circle = critical_circle(study)
    assert circle.fos == pytest.approx(1.369, rel=0.01)
    assert 15.0 < circle.entry_x_m < 20.0 and 38.0 < circle.exit_x_m < 41.0  # behind the crest, at the toe
    assert domain_warnings(study, circle) == []


@pytest.mark.parametrize("angle_deg", [60.0, 90.0])
def test_for_phi_0_the_critical_circle_is_the_least_circle(angle_deg):
    """Bishop's method on a circle is its moment equilibrium, exact for phi = 0: Taylor's toe circle
    (verification.least_circle) within 1%.  The vertical cut's face is a free side of its polygon:
    before, the section ran flat beyond it and no circle came out of the face (F = 7e13)."""
    text = (REPO / "studies" / "published" / "taylor_phi0.toml").read_text()
    study = parse_study(text[:text.index("[sweep]")].replace("angle_deg = 60.0", f"angle_deg = {angle_deg}"))
    least = slope_least_circle(5.0, angle_deg, 20e3, 20e3).fos
    assert critical_circle(study).fos == pytest.approx(least, rel=0.01)


def test_check_warns_before_the_run_that_the_domain_is_too_short():
    warnings = domain_warnings(parse_study(SHORT_DOMAIN))
    assert len(warnings) == 2 and all(w.startswith("warning: the domain may be too short") for w in warnings)
    assert any("behind the crest" in w for w in warnings) and any("beyond the toe" in w for w in warnings)
    assert all(math.isfinite(float(w.split("at least ")[1].split(" m")[0])) for w in warnings)
