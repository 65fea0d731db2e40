"""Tension cut-off after a shear return: the largest tension a plastic material can carry.

Shared by the frictional models (``drucker_prager``, ``mohr_coulomb``) and by ``tresca``; a
material with an infinite tensile strength (the default) skips it.  Conventions as in
``return_map``.
"""

from __future__ import annotations

from spfem_core.jit import kernel
from spfem_core.materials.return_map import (
    YIELD_RTOL,
    mohr_circle,
    plastic_measures,
    principal_direction,
    store_principal,
)
from spfem_core.state import XX, XY, YY, ZZ


@kernel
def tension_cutoff(stress, k_row, mean_stress_cap, tensile_strength, lame_lambda, shear_modulus):
    """Tension cut-off of row k_row after its shear return (in place); sigma_t = ``tensile_strength``.

    ``mean_stress_cap`` (Drucker-Prager): p = I1 / 3 <= sigma_t, returned along I at fixed deviator
    (volumetric plastic flow, dp = (p - sigma_t)).  Otherwise (Rankine): every principal stress
    s_i <= sigma_t, with plastic flow along the directions e_i of the active set A (the principal
    stresses held at sigma_t): for i in A
        s_i = s_i,tr - lambda sum_A dgamma - 2G dgamma_i = sigma_t,
    i.e. (lambda 1 1^T + 2G I) dgamma = s_A,tr - sigma_t, and the others lowered by lambda sum_A dgamma;
    A starts as the trial values above sigma_t, loses a member with dgamma < 0 and gains one left
    above sigma_t.  Both lower the shear yield function, so the state stays admissible.  Returns
    (equivalent plastic strain increment, dissipation in J/m^3) of the cut-off alone.
    """
    g = shear_modulus
    bulk = lame_lambda + 2.0 * g / 3.0
    sxx = stress[k_row, XX]
    syy = stress[k_row, YY]
    szz = stress[k_row, ZZ]
    sxy = stress[k_row, XY]
    if mean_stress_cap:
        mean = (sxx + syy + szz) / 3.0
        excess = mean - tensile_strength
        if excess <= YIELD_RTOL * (abs(mean) + abs(tensile_strength)):
            return 0.0, 0.0
        nxx, nyy, nzz, nxy = sxx - excess, syy - excess, szz - excess, sxy
        stress[k_row, XX] = nxx
        stress[k_row, YY] = nyy
        stress[k_row, ZZ] = nzz
        stress[k_row, XY] = nxy
        return plastic_measures(sxx - nxx, syy - nyy, szz - nzz, sxy - nxy, nxx, nyy, nzz, nxy, bulk, g)
    centre, half_diff, radius = mohr_circle(sxx, syy, sxy)
    largest = max(centre + radius, szz)
    if largest - tensile_strength <= YIELD_RTOL * (abs(largest) + abs(tensile_strength) + radius):
        return 0.0, 0.0
    cos_2t, sin_2t = principal_direction(half_diff, sxy, radius)
    ta = centre + radius
    tb = centre - radius
    tz = szz
    # active set: the principal stresses held at sigma_t; on it (lambda 1 1^T + 2G I) dgamma = s_A - sigma_t
    on_a = ta > tensile_strength
    on_b = tb > tensile_strength
    on_z = tz > tensile_strength
    sa, sb, sz = ta, tb, tz
    for _ in range(4):
        ea = ta - tensile_strength if on_a else 0.0
        eb = tb - tensile_strength if on_b else 0.0
        ez = tz - tensile_strength if on_z else 0.0
        m = (1.0 if on_a else 0.0) + (1.0 if on_b else 0.0) + (1.0 if on_z else 0.0)
        shared = lame_lambda * (ea + eb + ez) / (2.0 * g + m * lame_lambda)
        ga = (ea - shared) / (2.0 * g) if on_a else 0.0
        gb = (eb - shared) / (2.0 * g) if on_b else 0.0
        gz = (ez - shared) / (2.0 * g) if on_z else 0.0
        drop = lame_lambda * (ga + gb + gz)
        na = ta - drop - 2.0 * g * ga
        nb = tb - drop - 2.0 * g * gb
        nz = tz - drop - 2.0 * g * gz
        # drop a surface with negative flow, else take in one the return left above sigma_t
        if ga < 0.0 or gb < 0.0 or gz < 0.0:
            on_a = on_a and ga >= 0.0
            on_b = on_b and gb >= 0.0
            on_z = on_z and gz >= 0.0
            continue
        limit = tensile_strength + YIELD_RTOL * (abs(tensile_strength) + radius + abs(tz))
        if (not on_a and na > limit) or (not on_b and nb > limit) or (not on_z and nz > limit):
            on_a = on_a or na > limit
            on_b = on_b or nb > limit
            on_z = on_z or nz > limit
            continue
        sa = tensile_strength if on_a else na
        sb = tensile_strength if on_b else nb
        sz = tensile_strength if on_z else nz
        break
    nxx, nyy, nxy = store_principal(stress, k_row, sa, sb, sz, cos_2t, sin_2t)
    return plastic_measures(sxx - nxx, syy - nyy, szz - sz, sxy - nxy, nxx, nyy, sz, nxy, bulk, g)

