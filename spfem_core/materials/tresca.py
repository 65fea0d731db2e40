"""Tresca, perfectly plastic: an undrained clay of undrained shear strength c_u, plane strain.

With the principal stresses s1 >= s2 >= s3,

    f = s1 - s3 - 2 c_u,        flow N = e1 - e3 (associated: no plastic volume change).

The return is closed-form and keeps the mean stress p = (s1 + s2 + s3) / 3 (the flow is
deviatoric), so the returned principal stresses follow from f = 0 alone (de Souza Neto, Peric &
Owen 2008, section 8.1, box 8.1):

1. main plane:       r1 = m + c_u, r3 = m - c_u, r2 = s2,   m = (s1 + s3) / 2;  valid if r1 >= s2 >= r3;
2. else an edge:     s2 above r1: r1 = r2 = p + 2 c_u / 3, r3 = p - 4 c_u / 3  (s1 = s2, planes 1-3 and 2-3);
                     s2 below r3: r1 = p + 4 c_u / 3, r2 = r3 = p - 2 c_u / 3  (s2 = s3, planes 1-3 and 1-2).

There is no apex: the strength does not depend on the pressure.  The principal values go back
along the trial's principal directions.  An optional Rankine cut-off (``tension_cutoff``) caps
the largest principal stress at the tensile strength.  Strength reduction divides c_u and the
tensile strength by F.  It is Mohr-Coulomb with phi = psi = 0 (``tests/test_tresca.py`` holds
the two against each other).  Conventions of the return map: ``return_map``.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.jit import kernel
from spfem_core.materials.properties import Property
from spfem_core.materials.return_map import (
    YIELD_RTOL,
    accept_trial,
    elastic_trial,
    plastic_measures,
    sorted_principal,
    store_sorted,
)

NAME = "tresca"
CODE = 3

PROPERTIES = (
    Property("undrained_shear_strength_pa", ge=0.0),
    Property("tensile_strength_pa", default=math.inf, ge=0.0, inf_allowed=True),
)
"""c_u (Pa) and the tensile strength sigma_t (Pa; inf: no cut-off)."""

CONSTANTS = ("undrained_shear_strength_pa", "tensile_strength_pa")
"""Named columns of the kernel constants."""
UNDRAINED_SHEAR_STRENGTH, TENSILE_STRENGTH = range(len(CONSTANTS))


def check(properties: dict) -> str | None:
    """Tresca's properties need no cross-check."""
    return None


def constants(properties: dict, n_rows: int) -> tuple:
    """The columns of :data:`CONSTANTS`: the properties themselves."""
    return properties["undrained_shear_strength_pa"], properties["tensile_strength_pa"]


def reduced(properties: dict, srf: float, associated: bool) -> dict:
    """c_u,F = c_u / F and sigma_t,F = sigma_t / F (the flow is associated anyway)."""
    return properties | {"undrained_shear_strength_pa": properties["undrained_shear_strength_pa"] / srf,
                         "tensile_strength_pa": properties["tensile_strength_pa"] / srf}


def slip_strength(properties: dict, n_rows: int) -> tuple:
    """(c, tan phi) of a support the soil slides along: (c_u, 0)."""
    return properties["undrained_shear_strength_pa"].copy(), np.zeros(n_rows)


@kernel
def tresca_update(stress, k_row, dxx, dyy, dxy, lame_lambda, shear_modulus, undrained_strength):
    """Elastic trial and return of row k_row to Tresca (module doc), in place.  Returns (equivalent
    plastic strain increment, dissipation in J/m^3)."""
    g = shear_modulus
    bulk = lame_lambda + 2.0 * g / 3.0
    txx, tyy, tzz, txy = elastic_trial(stress, k_row, dxx, dyy, dxy, lame_lambda, g)
    s1, s2, s3, order, half_diff, radius = sorted_principal(txx, tyy, tzz, txy)
    two_cu = 2.0 * undrained_strength
    f = (s1 - s3) - two_cu
    if f <= YIELD_RTOL * (abs(s1) + abs(s3) + two_cu):
        return accept_trial(stress, k_row, txx, tyy, tzz, txy)
    mid = 0.5 * (s1 + s3)
    r1 = mid + undrained_strength
    r2 = s2
    r3 = mid - undrained_strength
    if s2 > r1 or s2 < r3:
        p = (s1 + s2 + s3) / 3.0
        if s2 > r1:  # s1 = s2
            r1 = p + two_cu / 3.0
            r2 = r1
            r3 = p - 2.0 * two_cu / 3.0
        else:  # s2 = s3
            r1 = p + 2.0 * two_cu / 3.0
            r2 = p - two_cu / 3.0
            r3 = r2
    store_sorted(stress, k_row, r1, r2, r3, order, half_diff, txy, radius)
    return plastic_measures(s1 - r1, s2 - r2, s3 - r3, 0.0, r1, r2, r3, 0.0, bulk, g)

