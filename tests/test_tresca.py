"""Tresca (``model = "tresca"``, undrained clay of strength c_u), the model added through the material
rooms: its return map against Mohr-Coulomb with phi = psi = 0, and the factor of safety of a slope."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spfem_core.materials.mohr_coulomb import mohr_coulomb_update
from spfem_core.materials.tresca import tresca_update
from workflows.cases import RunOptions
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

QUICKSTART = (Path(__file__).resolve().parents[1] / "studies" / "quickstart.toml").read_text()
PROPERTY = settings(deadline=None, max_examples=300)

YOUNGS_PA, NU = 2e7, 0.3
SHEAR = YOUNGS_PA / (2 * (1 + NU))
LAME = YOUNGS_PA * NU / ((1 + NU) * (1 - 2 * NU))


def principal(stress: np.ndarray) -> np.ndarray:
    """Principal stresses of a row (xx, yy, zz, xy), descending."""
    c, r = 0.5 * (stress[0] + stress[1]), math.hypot(0.5 * (stress[0] - stress[1]), stress[3])
    return np.sort([c + r, c - r, stress[2]])[::-1]


states = st.tuples(*(st.floats(-2e5, 2e5) for _ in range(4)), *(st.floats(-2e-2, 2e-2) for _ in range(3)),
                   st.floats(1e3, 5e4))
"""(sxx, syy, szz, sxy in Pa, dxx, dyy, dxy, c_u in Pa): a start state, a strain increment, a strength."""


@PROPERTY
@given(states)
def test_tresca_returns_where_mohr_coulomb_with_phi_zero_does(state):
    *stress, dxx, dyy, dxy, cu = state
    tresca, coulomb = np.array([stress]), np.array([stress])
    measures_t = tresca_update(tresca, 0, dxx, dyy, dxy, LAME, SHEAR, cu)
    measures_c = mohr_coulomb_update(coulomb, 0, dxx, dyy, dxy, LAME, SHEAR, cu, 0.0, 1.0, 0.0)
    scale = 2e5 + 2e-2 * 3 * (LAME + 2 * SHEAR)
    np.testing.assert_allclose(tresca, coulomb, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(measures_t, measures_c, rtol=1e-9, atol=1e-15 * scale)


@PROPERTY
@given(states)
def test_the_return_lands_on_the_surface_keeps_the_mean_stress_and_is_final(state):
    *stress, dxx, dyy, dxy, cu = state
    trial = np.array([stress]) + np.array([[LAME * (dxx + dyy) + 2 * SHEAR * dxx, LAME * (dxx + dyy) + 2 * SHEAR * dyy,
                                            LAME * (dxx + dyy), 2 * SHEAR * dxy]])
    row = np.array([stress])
    d_eq, work = tresca_update(row, 0, dxx, dyy, dxy, LAME, SHEAR, cu)
    s1, _, s3 = principal(row[0])
    scale = 2e5 + 2e-2 * 3 * (LAME + 2 * SHEAR)
    assert s1 - s3 <= 2 * cu + 1e-10 * scale
    assert np.sum(row[0, :3]) == pytest.approx(np.sum(trial[0, :3]), abs=1e-10 * scale)  # no plastic volume change
    if d_eq > 0:
        assert s1 - s3 == pytest.approx(2 * cu, abs=1e-10 * scale) and work > 0
        again = row.copy()
        assert tresca_update(again, 0, 0.0, 0.0, 0.0, LAME, SHEAR, cu) == (0.0, 0.0)
        np.testing.assert_array_equal(again, row)


def undrained(model_lines: str) -> str:
    """The quickstart slope as an undrained clay of c_u = 40 kPa given by ``model_lines``."""
    text = QUICKSTART.replace('model = "drucker_prager"\ndp_fit = "mohr_coulomb_match"\n', model_lines)
    text = text.replace("cohesion_pa = 10e3\nfriction_deg = 20.0\ndilation_deg = 0.0\n", "")
    return text.replace("srf_min = 1.0", "srf_min = 0.8").replace("srf_step = 0.1", "srf_step = 0.2")


def test_tresca_gives_the_factor_of_safety_of_mohr_coulomb_with_phi_zero(tmp_path):
    """The same slope, the same strength, two models: the same runs and FOS."""
    coulomb = run_study(parse_study(undrained('model = "mohr_coulomb"\ncohesion_pa = 40e3\nfriction_deg = 0.0\n')),
                        tmp_path / "mohr_coulomb", RunOptions(workers=2))
    tresca = run_study(parse_study(undrained('model = "tresca"\nundrained_shear_strength_pa = 40e3\n')),
                       tmp_path / "tresca", RunOptions(workers=2))
    assert math.isfinite(tresca.fos) and 0.8 < tresca.fos < 2.0
    assert (tresca.fos, tresca.fos_low, tresca.fos_high) == (coulomb.fos, coulomb.fos_low, coulomb.fos_high)
    decided = {r.srf: r.max_displacement_m for r in coulomb.runs if r.srf <= coulomb.fos_high}
    for record in tresca.runs:
        if record.srf in decided:
            assert record.max_displacement_m == pytest.approx(decided[record.srf], rel=1e-9)


def test_a_tresca_material_needs_its_strength():
    with pytest.raises(StudyError, match="undrained_shear_strength_pa: required field missing"):
        parse_study(undrained('model = "tresca"\n'))
