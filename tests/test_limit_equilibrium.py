"""Spencer's method on a given slip line (workflows.fos.limit_equilibrium) against closed forms and
Fredlund & Krahn (1977)."""

from __future__ import annotations

import numpy as np
import pytest

from workflows.fos.limit_equilibrium import Slices, material_strengths, spencer
from workflows.materials import MATERIAL_MODELS

# Fredlund & Krahn (1977), Can. Geotech. J. 14: 429-439, cases 1 and 3: a 2H:1V slope 40 ft high
# (crest at y = 60 ft from x = 0 to 60, toe at y = 20 ft from x = 140 to 170), c' = 600 psf,
# phi' = 20 deg, gamma = 120 pcf, the circle of centre (120, 90) ft and radius 80 ft.  Spencer:
# F = 2.073 (lambda 0.237) dry, 1.761 (lambda 0.255) with ru = 0.25; MacSlope's verification of the
# same cases (macslope.com/verification/fredlund-example): 2.076 (0.261) and 1.760 (0.252).
FK_GROUND = ([0.0, 60.0, 140.0, 170.0], [60.0, 60.0, 20.0, 20.0])
FK_SPENCER = {0.0: 2.073, 0.25: 1.761}


def _circle_slices(ru: float, n: int) -> Slices:
    centre_x, centre_y, radius = 120.0, 90.0, 80.0
    entry, exit_ = centre_x - np.sqrt(radius**2 - 30.0**2), centre_x + np.sqrt(radius**2 - 70.0**2)
    edges = np.linspace(entry, exit_, n + 1)
    middle = 0.5 * (edges[1:] + edges[:-1])

    def base(x):
        return centre_y - np.sqrt(radius**2 - (x - centre_x) ** 2)

    width = np.diff(edges)
    height = np.interp(middle, *FK_GROUND) - base(middle)
    weight = 120.0 * width * height
    return Slices(x_m=middle, y_m=base(middle), width_m=width, alpha_rad=np.arctan(-np.diff(base(edges)) / width),
                  vertical_load_n=weight, horizontal_load_n=np.zeros(n), horizontal_arm_m=np.zeros(n),
                  pore_pressure_pa=ru * 120.0 * height, cohesion_pa=np.full(n, 600.0),
                  tan_friction=np.full(n, np.tan(np.radians(20.0))))


@pytest.mark.parametrize("ru", [0.0, 0.25])
def test_spencer_matches_fredlund_and_krahn(ru):
    result = spencer(_circle_slices(ru, 400))
    assert result.fos == pytest.approx(FK_SPENCER[ru], rel=3e-3)
    assert abs(np.tan(result.theta_rad)) == pytest.approx(0.25, abs=0.02)  # lambda, 0.237-0.261 published


def test_spencer_converges_with_the_number_of_slices():
    fos = [spencer(_circle_slices(0.0, n)).fos for n in (25, 100, 400)]
    assert abs(fos[1] - fos[2]) < 0.25 * abs(fos[0] - fos[2])


@pytest.mark.parametrize("cohesion_pa, friction_deg, k", [(5e3, 30.0, 0.0), (0.0, 35.0, 0.0), (8e3, 25.0, 0.1)])
def test_a_planar_slip_gives_the_block_on_a_plane(cohesion_pa, friction_deg, k):
    """All slices on one plane of inclination a: theta = a balances the moments, and force
    equilibrium along the plane gives F = (c L + tan phi sum(W cos a - K sin a)) / sum(W sin a + K cos a),
    for any distribution of the weight over the slices."""
    alpha, n = np.radians(28.0), 40
    rng = np.random.default_rng(1)
    x = np.linspace(0.0, 30.0, n)
    width = np.full(n, x[1] - x[0])
    weight = 18e3 * width * rng.uniform(1.0, 6.0, n)
    horizontal = k * weight
    slices = Slices(x_m=x, y_m=-np.tan(alpha) * x, width_m=width, alpha_rad=np.full(n, alpha),
                    vertical_load_n=weight, horizontal_load_n=horizontal, horizontal_arm_m=np.zeros(n),
                    pore_pressure_pa=np.zeros(n), cohesion_pa=np.full(n, cohesion_pa),
                    tan_friction=np.full(n, np.tan(np.radians(friction_deg))))
    length = width.sum() / np.cos(alpha)
    expected = (cohesion_pa * length + np.tan(np.radians(friction_deg))
                * (weight * np.cos(alpha) - horizontal * np.sin(alpha)).sum()) / (
        (weight * np.sin(alpha) + horizontal * np.cos(alpha)).sum())
    result = spencer(slices)
    assert result.fos == pytest.approx(expected, rel=1e-9)
    if k == 0.0 and cohesion_pa > 0.0:  # (c = 0: every Q_i vanishes, theta is free)
        assert result.theta_rad == pytest.approx(-alpha, abs=1e-6)


def test_a_mass_that_drives_nothing_has_no_fos():
    slices = _circle_slices(0.0, 50)
    flat = Slices(**{**slices.__dict__, "alpha_rad": np.zeros(50)})
    result = spencer(flat)
    assert np.isnan(result.fos) and "no motion" in result.reason


def test_a_slice_has_the_strength_its_materials_core_model_gives_a_slip_support():
    """The strength of a study's material along a slip line is its core model's ``slip_strength``
    (the strength of a support the soil slides along), whatever its fields are called: c' and
    phi' (the peak values of a softening soil), c_u and phi = 0 of Tresca, none (c = inf) elastic."""
    shared = {"density_kg_m3": 2000.0, "youngs_modulus_pa": 1e8, "poisson_ratio": 0.3}
    materials = [
        MATERIAL_MODELS["mohr_coulomb"](name="sand", cohesion_pa=5e3, friction_deg=30.0, softening="linear",
                                        residual_cohesion_pa=1e3, residual_friction_deg=25.0,
                                        softening_end_strain=0.1, **shared),
        MATERIAL_MODELS["drucker_prager"](name="silt", cohesion_pa=8e3, friction_deg=20.0, **shared),
        MATERIAL_MODELS["tresca"](name="clay", undrained_shear_strength_pa=30e3, **shared),
        MATERIAL_MODELS["elastic"](name="rock", **shared),
    ]
    cohesion_pa, tan_friction = material_strengths(materials)
    np.testing.assert_array_equal(cohesion_pa, [5e3, 8e3, 30e3, np.inf])
    np.testing.assert_array_equal(tan_friction, [np.tan(np.radians(30.0)), np.tan(np.radians(20.0)), 0.0, 0.0])
