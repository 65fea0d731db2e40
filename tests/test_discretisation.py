"""The expected discretisation excess a FOS at one spacing carries (``workflows.fos.discretisation``):
read from the slopes it was measured on, scaled at first order in h, said with its cure."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from workflows.fos.discretisation import MEASURED, expected_excess, note
from workflows.study import parse_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()


def test_the_quickstart_is_told_the_excess_of_the_slopes_of_its_friction_angle():
    """phi = 20 deg at H/10: the slopes of 15-25 deg measured +1.6% to +2.8% at H/10."""
    low, high, count = expected_excess(parse_study(QUICKSTART))
    near = [excess for _, phi, excess in MEASURED if 15.0 <= phi <= 25.0]
    assert (low, high, count) == (pytest.approx(min(near)), pytest.approx(max(near)), len(near))


def test_the_excess_scales_with_the_spacing_at_first_order():
    coarse = expected_excess(parse_study(QUICKSTART))
    fine = expected_excess(parse_study(QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 0.5")))
    assert fine[0] == pytest.approx(0.5 * coarse[0]) and fine[1] == pytest.approx(0.5 * coarse[1])


def test_a_friction_angle_never_measured_is_said_and_every_note_names_the_cure():
    steep = parse_study(QUICKSTART.replace("friction_deg = 20.0", "friction_deg = 55.0"))
    assert expected_excess(steep) is None and "not measured" in note(steep)
    line = note(parse_study(QUICKSTART))
    assert "[refinement]" in line and re.search(r"H/10\b", line)
