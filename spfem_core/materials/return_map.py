"""What the return maps of the plastic models share: the elastic trial and the plastic measures.

Plane strain, tension positive, stress row (xx, yy, zz, xy); the strain increment is
(d_xx, d_yy, d_xy) with tensor shear and d_zz = 0.  Elasticity: Lame lambda, shear modulus
G, bulk modulus K = lambda + 2G/3.  Invariants: p = I1/3, s = sigma - p I,
J2 = s:s/2 = (s_xx^2 + s_yy^2 + s_zz^2)/2 + s_xy^2.

Every plastic model takes the elastic trial sigma_tr = sigma + lambda tr(d) I + 2 G d (zz gets
lambda tr(d)), keeps it when it is admissible, and otherwise returns it to its yield surface
by backward Euler (closed forms: the surfaces are linear in stress).  The plastic strain of
the step is d_eps_p = C^-1 (sigma_tr - sigma_new); each return map returns

    (sqrt(2/3 d_eps_p : d_eps_p),  sigma_new : d_eps_p)

the equivalent plastic strain increment and the plastic dissipation per volume (J/m^3),
shear components counted twice in both contractions.

A trial with f <= YIELD_RTOL * (size of the terms of f) counts as elastic: a state the
return map produced is then accepted as it is, so a second return is an exact no-op.
"""

from __future__ import annotations

import math

from spfem_core.jit import inline_kernel, inner_kernel
from spfem_core.state import XX, XY, YY, ZZ

YIELD_RTOL = 1e-12
"""Relative tolerance of the yield check: f <= YIELD_RTOL * scale counts as elastic."""


@inner_kernel
def plastic_measures(dsxx, dsyy, dszz, dsxy, nxx, nyy, nzz, nxy, bulk_modulus, shear_modulus):
    """From dsigma = sigma_tr - sigma_new (coaxial or not) and sigma_new:

    d_eps_p = C^-1 dsigma = (dsigma - dp I) / (2G) + dp / (3K) I,  dp = tr(dsigma) / 3
    returns (sqrt(2/3 d_eps_p : d_eps_p), sigma_new : d_eps_p), shear counted twice.
    """
    dp = (dsxx + dsyy + dszz) / 3.0
    vol = dp / (3.0 * bulk_modulus)
    inv_2g = 0.5 / shear_modulus
    exx = (dsxx - dp) * inv_2g + vol
    eyy = (dsyy - dp) * inv_2g + vol
    ezz = (dszz - dp) * inv_2g + vol
    exy = dsxy * inv_2g
    norm2 = exx * exx + eyy * eyy + ezz * ezz + 2.0 * exy * exy
    work = nxx * exx + nyy * eyy + nzz * ezz + 2.0 * nxy * exy
    return math.sqrt(2.0 / 3.0 * norm2), work


@inner_kernel
def elastic_trial(stress, k_row, dxx, dyy, dxy, lame_lambda, shear_modulus):
    """Trial stress sigma + lambda tr(d) I + 2 G d of row ``k_row`` (plane strain, d_zz = 0),
    returned as (xx, yy, zz, xy) without writing it."""
    volumetric = lame_lambda * (dxx + dyy)
    return (
        stress[k_row, XX] + (volumetric + 2.0 * shear_modulus * dxx),
        stress[k_row, YY] + (volumetric + 2.0 * shear_modulus * dyy),
        stress[k_row, ZZ] + volumetric,
        stress[k_row, XY] + 2.0 * shear_modulus * dxy,
    )


@inline_kernel
def accept_trial(stress, k_row, txx, tyy, tzz, txy):
    """Write an admissible trial stress to row ``k_row`` as it is: no plastic strain, no dissipation, (0, 0)."""
    stress[k_row, XX] = txx
    stress[k_row, YY] = tyy
    stress[k_row, ZZ] = tzz
    stress[k_row, XY] = txy
    return 0.0, 0.0


@inline_kernel
def mohr_circle(sxx, syy, sxy):
    """(centre, half difference, radius) of the in-plane Mohr circle of (xx, yy, xy): the in-plane
    principal values are centre +- radius."""
    centre = 0.5 * (sxx + syy)
    half_diff = 0.5 * (sxx - syy)
    return centre, half_diff, math.sqrt(half_diff * half_diff + sxy * sxy)


@inline_kernel
def principal_direction(half_diff, sxy, radius):
    """(cos 2 theta, sin 2 theta) of the major in-plane principal direction; (1, 0) for a point circle."""
    if radius > 0.0:
        return half_diff / radius, sxy / radius
    return 1.0, 0.0


@inline_kernel
def store_principal(stress, k_row, na, nb, nz, cos_2t, sin_2t):
    """Write principal values na, nb (in-plane, along the directions of cos 2 theta, sin 2 theta)
    and nz (out of plane) back to row ``k_row`` as (xx, yy, zz, xy); returns the new (xx, yy, xy)."""
    new_centre = 0.5 * (na + nb)
    new_half = 0.5 * (na - nb)
    nxx = new_centre + new_half * cos_2t
    nyy = new_centre - new_half * cos_2t
    nxy = new_half * sin_2t
    stress[k_row, XX] = nxx
    stress[k_row, YY] = nyy
    stress[k_row, ZZ] = nz
    stress[k_row, XY] = nxy
    return nxx, nyy, nxy


@inline_kernel
def sorted_principal(sxx, syy, szz, sxy):
    """The principal stresses of (xx, yy, zz, xy) sorted s1 >= s2 >= s3: (s1, s2, s3, order,
    half difference, radius), ``order`` saying where zz stands (0: first, 1: second, 2: third)."""
    centre, half_diff, radius = mohr_circle(sxx, syy, sxy)
    sa = centre + radius  # major in-plane
    sb = centre - radius  # minor in-plane
    if szz >= sa:
        return szz, sa, sb, 0, half_diff, radius  # (zz, a, b)
    if szz >= sb:
        return sa, szz, sb, 1, half_diff, radius  # (a, zz, b)
    return sa, sb, szz, 2, half_diff, radius  # (a, b, zz)


@inline_kernel
def store_sorted(stress, k_row, r1, r2, r3, order, half_diff, sxy, radius):
    """Write sorted principal values r1 >= r2 >= r3 back to row ``k_row`` along the directions of the
    state :func:`sorted_principal` sorted (its ``order``, half difference, xy and radius)."""
    if order == 0:
        na, nb, nz = r2, r3, r1
    elif order == 1:
        na, nb, nz = r1, r3, r2
    else:
        na, nb, nz = r1, r2, r3
    cos_2t, sin_2t = principal_direction(half_diff, sxy, radius)
    store_principal(stress, k_row, na, nb, nz, cos_2t, sin_2t)
