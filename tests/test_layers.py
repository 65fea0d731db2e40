"""A material layer thinner than four particle spacings is named before the study runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from workflows.layers import MIN_ROWS, layer_thickness_m, thin_layer_warnings
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()
SOIL = QUICKSTART[QUICKSTART.index("[[materials]]"):QUICKSTART.index("[loads]")]
WEAK_LAYER = (SOIL.replace('name = "soil"', 'name = "weak"').replace("cohesion_pa = 10e3", "cohesion_pa = 2e3")
              + "region_m = [[0.0, 4.6], [60.0, 4.6], [60.0, 5.4], [0.0, 5.4]]\n")
"""The quickstart's soil, weaker, in a band 0.8 m thick across the domain."""


def layered(spacing_m: float) -> str:
    text = QUICKSTART.replace("spacing_m = 1.0", f"spacing_m = {spacing_m:g}")
    return text.replace("[loads]", WEAK_LAYER + "\n[loads]", 1)


@pytest.mark.parametrize("spacing_m", [0.2, 0.1])
def test_the_thickness_of_a_layer_is_measured_within_a_spacing(spacing_m):
    """A band 0.8 m thick across the whole domain."""
    thickness, spacing = layer_thickness_m(parse_study(layered(spacing_m)))["weak"]
    assert thickness == pytest.approx(0.8, abs=spacing_m) and spacing == spacing_m


def test_a_layer_thinner_than_four_spacings_is_named_with_its_thickness_and_a_spacing_that_resolves_it():
    coarse = thin_layer_warnings(parse_study(layered(0.5)))
    assert len(coarse) == 1 and "'weak'" in coarse[0] and f"fewer than {MIN_ROWS} rows" in coarse[0]
    assert thin_layer_warnings(parse_study(layered(0.15))) == []
    assert thin_layer_warnings(parse_study(QUICKSTART)) == []  # one material fills the domain
    zone = ('[[geometry.refined]]\nname = "layer"\nregion_m = [[0.0, 4.0], [60.0, 4.0], [60.0, 6.0], [0.0, 6.0]]\n'
            'spacing_m = 0.15\n\n[[materials]]')
    assert thin_layer_warnings(parse_study(layered(0.5).replace("[[materials]]", zone, 1))) == []  # refined there


def _band(y_m: float, thickness_m: float) -> str:
    weak = WEAK_LAYER.replace("region_m = [[0.0, 4.6], [60.0, 4.6], [60.0, 5.4], [0.0, 5.4]]",
                              f"region_m = [[0.0, {y_m}], [60.0, {y_m}], [60.0, {y_m + thickness_m}], "
                              f"[0.0, {y_m + thickness_m}]]")
    return QUICKSTART.replace("[loads]", weak + "\n[loads]", 1)


@pytest.mark.parametrize("thickness_m", [0.01, 0.8])
def test_a_layer_of_one_row_of_particles_is_not_given_a_thickness_the_cloud_cannot_measure(thickness_m):
    """At h = 1 m a 1 cm band and a 0.8 m band both hold one row of particles (the lattice row at
    y = 5): both measure 1 m, and were reported as "about 1 m thick"; the warning says one row, thinner
    than about two spacings, and gives no spacing computed from the false thickness."""
    warning, = thin_layer_warnings(parse_study(_band(5.0 - thickness_m / 2.0, thickness_m)))
    assert "one row of particles thick at a spacing of 1 m (so thinner than about 2 m" in warning
    assert "about 1 m thick" not in warning and "at most a quarter of its thickness" in warning


def test_a_layer_that_holds_no_particle_says_why_on_the_field_that_placed_it():
    from workflows.scene import build_scene

    with pytest.raises(StudyError, match="'weak' holds no particle: its region is thinner than the particle spacing "
                                         r"there \(1 m\)") as error:
        build_scene(parse_study(_band(4.6, 0.01)))  # between the lattice rows y = 4 and 5
    assert error.value.field == "materials[1]"
    with pytest.raises(StudyError, match="its region lies outside geometry.polygon_m"):
        build_scene(parse_study(_band(-30.0, 1.0)))
