"""A material layer thinner than four particle spacings is named before the study runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from workflows.layers import MIN_ROWS, layer_thickness_m, thin_layer_warnings
from workflows.study import parse_study

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
