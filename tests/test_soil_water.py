"""Soil-water characteristic curves (van Genuchten-Mualem, Gardner) and the suction stress."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spfem_core.soil_water import Gardner, VanGenuchten
from spfem_core.suction_stress import suction_stress_pa

CURVES = [VanGenuchten(0.05, 0.40, 1.0, 1.3), VanGenuchten(0.06, 0.45, 2.0, 1.6, 1e-4),
          VanGenuchten(0.0, 0.35, 0.5, 2.5), VanGenuchten(0.1, 0.5, 3.0, 5.0), Gardner(0.06, 0.40, 1.0),
          Gardner(0.0, 0.3, 5.0, 1e-5)]
SUCTIONS = -np.logspace(-3, 2, 200)  # psi from -1 mm to -100 m


@pytest.mark.parametrize("curve", CURVES, ids=lambda c: f"{type(c).__name__}-{c.alpha_1_m}")
def test_the_moisture_capacity_is_the_derivative_of_the_water_content(curve):
    """C(psi) against central differences of theta (step 1e-6 |psi|): within 1e-6 of the largest C."""
    step = 1e-6 * np.abs(SUCTIONS)
    numerical = (curve.water_content(SUCTIONS + step) - curve.water_content(SUCTIONS - step)) / (2.0 * step)
    np.testing.assert_allclose(curve.moisture_capacity_1_m(SUCTIONS), numerical, rtol=1e-6,
                               atol=1e-6 * np.max(numerical))


@pytest.mark.parametrize("curve", CURVES, ids=lambda c: f"{type(c).__name__}-{c.alpha_1_m}")
def test_the_curves_are_monotonic_and_saturated_from_zero_up(curve):
    """S_e, theta and k_r rise with psi; C >= 0; at psi >= 0 S_e = k_r = 1, theta = theta_s, C = 0; they tend
    to 1 as psi -> 0- and to 0 (theta to theta_r) as psi -> -inf (slowly for van Genuchten's small n:
    S_e ~ (alpha |psi|)^(1 - n))."""
    psi = np.concatenate([-np.logspace(6, -9, 400), [0.0, 1e-9, 0.5, 10.0]])
    for values in (curve.effective_saturation(psi), curve.water_content(psi), curve.relative_conductivity(psi)):
        assert np.all(np.diff(values) >= 0.0)
    assert np.all(curve.moisture_capacity_1_m(psi) >= 0.0)
    wet = psi >= 0.0
    assert np.all(curve.effective_saturation(psi[wet]) == 1.0) and np.all(curve.relative_conductivity(psi[wet]) == 1.0)
    assert np.all(curve.moisture_capacity_1_m(psi[wet]) == 0.0)
    assert np.all(curve.water_content(psi[wet]) == curve.saturated_water_content)
    assert curve.effective_saturation(-1e-9) == pytest.approx(1.0, abs=1e-6)
    assert curve.relative_conductivity(-1e-12) == pytest.approx(1.0, abs=1e-3)
    assert curve.effective_saturation(-1e100) < 1e-20 and curve.relative_conductivity(-1e100) < 1e-40
    assert curve.water_content(-1e100) == pytest.approx(curve.residual_water_content, abs=1e-20)


def test_mualems_conductivity_is_the_textbook_formula_and_stays_accurate_when_dry():
    """k_r = S_e^(1/2) [1 - (1 - S_e^(1/m))^m]^2 to 1e-10 where that form is well conditioned; in dry soil,
    where it cancels to 0, the asymptote (1 + x)^(-m/2) (m / (1 + x))^2 (x = (alpha |psi|)^n) within 1e-4."""
    curve = VanGenuchten(0.05, 0.40, 2.0, 1.8)
    m = curve.m
    psi = -np.logspace(-2, 1, 50)
    se = curve.effective_saturation(psi)
    textbook = np.sqrt(se) * (1.0 - (1.0 - se ** (1.0 / m)) ** m) ** 2
    np.testing.assert_allclose(curve.relative_conductivity(psi), textbook, rtol=1e-10)
    dry = -np.logspace(5, 8, 10)
    x = (curve.alpha_1_m * -dry) ** curve.n
    np.testing.assert_allclose(curve.relative_conductivity(dry), (1.0 + x) ** (-m / 2) * (m / (1.0 + x)) ** 2, rtol=1e-4)
    assert np.all(curve.relative_conductivity(dry) > 0.0)


def test_gardners_curve_is_its_exponential():
    curve = Gardner(0.06, 0.40, 1.5)
    psi = np.array([-4.0, -1.0, -0.1])
    np.testing.assert_allclose(curve.relative_conductivity(psi), np.exp(1.5 * psi), rtol=1e-15)
    np.testing.assert_allclose(curve.water_content(psi), 0.06 + 0.34 * np.exp(1.5 * psi), rtol=1e-15)
    np.testing.assert_allclose(curve.moisture_capacity_1_m(psi), 0.34 * 1.5 * np.exp(1.5 * psi), rtol=1e-15)


@pytest.mark.parametrize("make, match", [
    (lambda: VanGenuchten(0.4, 0.4, 1.0, 1.5), "theta_r < theta_s"),
    (lambda: VanGenuchten(0.05, 1.2, 1.0, 1.5), "theta_s <= 1"),
    (lambda: VanGenuchten(0.05, 0.4, 0.0, 1.5), "alpha > 0"),
    (lambda: VanGenuchten(0.05, 0.4, 1.0, 1.0), "n > 1"),
    (lambda: VanGenuchten(0.05, 0.4, 1.0, math.nan), "n > 1"),
    (lambda: VanGenuchten(0.05, 0.4, 1.0, 1.5, -1e-4), "S_s >= 0"),
    (lambda: Gardner(0.05, 0.4, -1.0), "a > 0"),
])
def test_a_curve_refuses_parameters_outside_their_range(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_the_suction_stress_is_terzaghis_below_the_water_table_and_lu_and_likos_above():
    """sigma_s = gamma_w psi at psi >= 0; above, Lu & Likos's (2006) closed form for van Genuchten's curve,
    sigma_s = -(u_a - u_w) / (1 + (alpha' (u_a - u_w))^n)^((n - 1)/n), alpha' = alpha / gamma_w (1/kPa), suction in kPa."""
    curve = VanGenuchten(0.05, 0.40, 2.0, 1.8)
    psi = np.array([3.0, 0.0, -0.1, -1.0, -10.0])
    stress = suction_stress_pa(curve, psi, 9810.0)
    assert stress[0] == pytest.approx(9810.0 * 3.0) and stress[1] == 0.0
    suction_kpa = -9.81 * psi[2:]
    closed = -suction_kpa / (1.0 + (2.0 / 9.81 * suction_kpa) ** 1.8) ** (0.8 / 1.8)
    np.testing.assert_allclose(stress[2:] / 1e3, closed, rtol=1e-12)
    assert np.all(stress[2:] < 0.0)


@pytest.mark.parametrize("curve", CURVES, ids=lambda c: f"{type(c).__name__}-{c.alpha_1_m}")
def test_the_values_at_once_are_the_four_functions(curve):
    """``values`` (what the transient solver calls) gives S_e, theta, C and k_r as the separate functions do."""
    psi = np.concatenate([SUCTIONS, -np.logspace(3, 300, 5), [0.0, 2.0]])
    values = curve.values(psi)
    np.testing.assert_allclose(values.effective_saturation, curve.effective_saturation(psi), rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(values.water_content, curve.water_content(psi), rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(values.moisture_capacity_1_m, curve.moisture_capacity_1_m(psi), rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(values.relative_conductivity, curve.relative_conductivity(psi), rtol=1e-14, atol=0.0)
