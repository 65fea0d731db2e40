"""Linear elastic material, plane strain: Hooke's law and its energy.

    sigma += lambda tr(d) I + 2 G d      (d_zz = 0, so s_zz += lambda tr(d))

with Lame's lambda = K - 2G/3, G = E / (2 (1 + nu)), K = E / (3 (1 - 2 nu)).  The model has no
properties of its own and no kernel constants; strength reduction leaves it alone.  Every other
model uses its elasticity inside the yield surface, and the energy budget its complementary
energy (:func:`elastic_energy_density`).
"""

from __future__ import annotations

import numpy as np

from spfem_core.jit import inner_kernel, kernel
from spfem_core.state import XX, XY, YY, ZZ

NAME = "elastic"
CODE = 0
PROPERTIES = ()
CONSTANTS = ()
"""Named columns of the kernel constants (``table.MaterialTable.kernel_constants``): none."""


def check(properties: dict) -> str | None:
    """Nothing to check together."""
    return None


def constants(properties: dict, n_rows: int) -> tuple:
    """The kernel constants of ``n_rows`` elastic rows: none."""
    return ()


def reduced(properties: dict, srf: float, associated: bool) -> dict:
    """Strength reduction: nothing to reduce."""
    return properties


def slip_strength(properties: dict, n_rows: int) -> tuple:
    """(c, tan phi) of a support the soil slides along: an elastic soil has no strength to slide
    with (c = inf), so such a support holds it fixed."""
    return np.full(n_rows, np.inf), np.zeros(n_rows)


@kernel
def elastic_increment(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus):
    """sigma_k += lambda tr(d) I + 2 G d, plane strain (d_zz = 0); d_xy is the tensor shear."""
    volumetric = lame_lambda * (dxx + dyy)
    stress[k, XX] += volumetric + 2.0 * shear_modulus * dxx
    stress[k, YY] += volumetric + 2.0 * shear_modulus * dyy
    stress[k, ZZ] += volumetric
    stress[k, XY] += 2.0 * shear_modulus * dxy


@inner_kernel
def elastic_energy_density(sxx, syy, szz, sxy, youngs_modulus, poisson_ratio):
    """Complementary energy per volume of an isotropic elastic state (J/m^3).

    w = [s_xx^2 + s_yy^2 + s_zz^2 - 2 nu (s_xx s_yy + s_yy s_zz + s_zz s_xx)] / (2E) + s_xy^2 / (2G)
    """
    shear_modulus = youngs_modulus / (2.0 * (1.0 + poisson_ratio))
    normal = sxx * sxx + syy * syy + szz * szz - 2.0 * poisson_ratio * (sxx * syy + syy * szz + szz * sxx)
    return normal / (2.0 * youngs_modulus) + sxy * sxy / (2.0 * shear_modulus)
