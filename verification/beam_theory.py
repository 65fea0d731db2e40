"""Plane-strain Euler-Bernoulli theory of the cantilever of ``verification.scenes.beam_scene``.

Per metre of out-of-plane thickness: bending stiffness E' I with the plane-strain modulus
E' = E / (1 - nu^2) and I = d^3 / 12, mass per length rho A with A = d, load q = rho g A.

    static tip deflection under self weight   w = q L^4 / (8 E' I)
    first natural period                       T = 2 pi / (beta_1^2 sqrt(E' I / (rho A L^4))),
                                               beta_1 = 1.8751040687 (cos b cosh b = -1)

For the scene (L = 2 m, d = 0.2 m, E = 80 MPa, nu = 0.25, rho = 1850 kg m-3, g = 9.8 m s-2):
0.1275 m and 0.5765 s.  Shear deformation and rotary inertia (Timoshenko) lengthen the period
of this 10:1 beam by 1-2%.
"""

from __future__ import annotations

import math

from verification.scenes import (
    BEAM_DENSITY_KG_M3,
    BEAM_DEPTH_M,
    BEAM_GRAVITY_M_S2,
    BEAM_LENGTH_M,
    BEAM_POISSON_RATIO,
    BEAM_YOUNGS_MODULUS_PA,
)

FIRST_MODE_BETA_L = 1.8751040687
"""Smallest root of cos(b) cosh(b) = -1: the first mode of a clamped-free beam."""


def plane_strain_bending_stiffness_n_m2() -> float:
    """E' I = E / (1 - nu^2) d^3 / 12 per metre of thickness (N m^2 / m)."""
    modulus = BEAM_YOUNGS_MODULUS_PA / (1.0 - BEAM_POISSON_RATIO**2)
    return modulus * BEAM_DEPTH_M**3 / 12.0


def static_tip_deflection_m() -> float:
    """w = q L^4 / (8 E' I), q = rho g d (module doc)."""
    load = BEAM_DENSITY_KG_M3 * BEAM_GRAVITY_M_S2 * BEAM_DEPTH_M
    return load * BEAM_LENGTH_M**4 / (8.0 * plane_strain_bending_stiffness_n_m2())


def first_period_s() -> float:
    """T = 2 pi / (beta_1^2 sqrt(E' I / (rho A L^4))) (module doc)."""
    mass_per_length = BEAM_DENSITY_KG_M3 * BEAM_DEPTH_M
    omega = FIRST_MODE_BETA_L**2 * math.sqrt(plane_strain_bending_stiffness_n_m2() / (mass_per_length * BEAM_LENGTH_M**4))
    return 2.0 * math.pi / omega
