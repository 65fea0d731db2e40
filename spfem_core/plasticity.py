"""Perfectly plastic soil: Drucker-Prager and Mohr-Coulomb return maps for one particle.

Plane strain, tension positive, stress row (xx, yy, zz, xy); the strain increment is
(d_xx, d_yy, d_xy) with tensor shear and d_zz = 0.  Elasticity: Lame lambda, shear modulus
G, bulk modulus K = lambda + 2G/3.  Invariants: p = I1/3, s = sigma - p I,
J2 = s:s/2 = (s_xx^2 + s_yy^2 + s_zz^2)/2 + s_xy^2.

Both kernels take the elastic trial sigma_tr = sigma + lambda tr(d) I + 2 G d (zz gets
lambda tr(d)), keep it when it is admissible, and otherwise return it to the yield surface
by backward Euler (exact closed forms: both surfaces are linear in stress).  The plastic
strain of the step is d_eps_p = C^-1 (sigma_tr - sigma_new); each kernel returns

    (sqrt(2/3 d_eps_p : d_eps_p),  sigma_new : d_eps_p)

the equivalent plastic strain increment and the plastic dissipation per volume (J/m^3),
shear components counted twice in both contractions.

A trial with f <= YIELD_RTOL * (size of the terms of f) counts as elastic: a state the
return map produced is then accepted as it is, so a second return is an exact no-op.

Drucker-Prager (section 2 of the method notes):

    f = alpha I1 + sqrt(J2) - k,          g = sqrt(J2) + alpha_psi I1
    d_eps_p = dlambda (s / (2 sqrt(J2)) + alpha_psi I)

Mohr-Coulomb (de Souza Neto, Peric & Owen 2008, sections 8.2-8.3, boxes 8.4-8.5), with
principal stresses s1 >= s2 >= s3:

    f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c cos(phi),    g = (s1 - s3) + (s1 + s3) sin(psi)
"""

from __future__ import annotations

import math

from spfem_core.jit import inner_kernel, kernel

YIELD_RTOL = 1e-12
"""Relative tolerance of the yield check: f <= YIELD_RTOL * scale counts as elastic."""

DP_FITS = ("inner", "outer", "plane_strain_associated", "plane_strain_nonassociated")
"""Drucker-Prager matches to Mohr-Coulomb (method notes, section 2), see ``dp_constants``."""


# ----------------------------------------------------------------------------------------
# Drucker-Prager constants (plain Python, used when building material tables)
# ----------------------------------------------------------------------------------------


def _check_strength(cohesion_pa, friction_deg, dilation_deg):
    for name, value in (("cohesion_pa", cohesion_pa), ("friction_deg", friction_deg),
                        ("dilation_deg", dilation_deg)):
        if not math.isfinite(value):
            raise ValueError(f"{name}: must be a finite number, got {value}")
    if cohesion_pa < 0.0:
        raise ValueError(f"cohesion_pa: must be >= 0, got {cohesion_pa}")
    if not 0.0 <= friction_deg < 90.0:
        raise ValueError(f"friction_deg: must be in [0, 90), got {friction_deg}")
    if not 0.0 <= dilation_deg <= friction_deg:
        raise ValueError(f"dilation_deg: must be in [0, friction_deg = {friction_deg}], got {dilation_deg}")


def _cone_alpha(sin_angle, sign):
    """2 sin / (sqrt3 (3 + sign sin)): sign +1 inner (extension) cone, -1 outer (compression) cone."""
    return 2.0 * sin_angle / (math.sqrt(3.0) * (3.0 + sign * sin_angle))


def _plane_strain_alpha(tan_angle):
    """tan / sqrt(9 + 12 tan^2): the plane-strain match for associated flow."""
    return tan_angle / math.sqrt(9.0 + 12.0 * tan_angle * tan_angle)


def dp_constants(cohesion_pa: float, friction_deg: float, dilation_deg: float, fit: str):
    """Drucker-Prager (alpha, k in Pa, alpha_psi) matched to Mohr-Coulomb (c, phi, psi) by ``fit``.

    f = alpha I1 + sqrt(J2) - k, g = sqrt(J2) + alpha_psi I1.

    - "inner":  alpha = 2 sin(phi) / (sqrt3 (3 + sin(phi))), k = 6 c cos(phi) / (sqrt3 (3 + sin(phi)));
    - "outer":  the same with 3 - sin(phi);
    - "plane_strain_associated": alpha = tan(phi) / sqrt(9 + 12 tan^2 phi), k = 3 c / sqrt(9 + 12 tan^2 phi);
      matches Mohr-Coulomb at plane-strain collapse for psi = phi only.
    For these three, alpha_psi is the fit's alpha formula with psi in place of phi.

    - "plane_strain_nonassociated": the plane-strain collapse match for any 0 <= psi <= phi,
        alpha_psi = tan(psi) / sqrt(9 + 12 tan^2 psi),  q = sqrt(1 - 3 alpha_psi^2),
        alpha = sin(phi) / (q (3 + sin(phi) sin(psi))),  k = 3 c cos(phi) / (q (3 + sin(phi) sin(psi))).
      psi = 0 gives the table row of the method notes (sin(phi)/3, c cos(phi), 0); psi = phi
      gives the associated row.  Derivation: at collapse in plane strain the stress is
      stationary, so d_eps_p_zz = 0, i.e. s_zz = -2 alpha_psi sqrt(J2); then
      J2 = R^2 / (1 - 3 alpha_psi^2) and p = m - alpha_psi sqrt(J2) with R the radius and m
      the centre of the in-plane Mohr circle, and f = 0 becomes
      R (1 - 3 alpha alpha_psi) / q + 3 alpha m - k = 0, which is R + m sin(phi) - c cos(phi) = 0
      for the alpha, k above; alpha_psi makes the plastic dilatancy d_eps_v / (d_eps_1 - d_eps_3)
      equal Mohr-Coulomb's sin(psi).
    """
    _check_strength(cohesion_pa, friction_deg, dilation_deg)
    phi = math.radians(friction_deg)
    psi = math.radians(dilation_deg)
    c = float(cohesion_pa)
    if fit in ("inner", "outer"):
        sign = 1.0 if fit == "inner" else -1.0
        alpha = _cone_alpha(math.sin(phi), sign)
        k = 6.0 * c * math.cos(phi) / (math.sqrt(3.0) * (3.0 + sign * math.sin(phi)))
        return alpha, k, _cone_alpha(math.sin(psi), sign)
    if fit == "plane_strain_associated":
        tan_phi = math.tan(phi)
        return (_plane_strain_alpha(tan_phi), 3.0 * c / math.sqrt(9.0 + 12.0 * tan_phi * tan_phi),
                _plane_strain_alpha(math.tan(psi)))
    if fit == "plane_strain_nonassociated":
        alpha_psi = _plane_strain_alpha(math.tan(psi))
        q = math.sqrt(1.0 - 3.0 * alpha_psi * alpha_psi)
        denominator = q * (3.0 + math.sin(phi) * math.sin(psi))
        return math.sin(phi) / denominator, 3.0 * c * math.cos(phi) / denominator, alpha_psi
    raise ValueError(f"fit: must be one of {DP_FITS}, got {fit!r}")


def default_dp_fit(dilation_deg: float, friction_deg: float | None = None) -> str:
    """The Drucker-Prager fit that matches Mohr-Coulomb at plane-strain collapse for this dilation.

    "plane_strain_associated" when psi = phi (associated flow), otherwise
    "plane_strain_nonassociated" (exact for every 0 <= psi <= phi; at psi = phi both give
    the same constants).  Without ``friction_deg`` the flow is taken as non-associated.
    """
    if not (math.isfinite(dilation_deg) and dilation_deg >= 0.0):
        raise ValueError(f"dilation_deg: must be a finite number >= 0, got {dilation_deg}")
    if friction_deg is not None and dilation_deg > 0.0 and dilation_deg == friction_deg:
        return "plane_strain_associated"
    return "plane_strain_nonassociated"


# ----------------------------------------------------------------------------------------
# Return maps (compiled)
# ----------------------------------------------------------------------------------------


@inner_kernel
def _plastic_measures(dsxx, dsyy, dszz, dsxy, nxx, nyy, nzz, nxy, bulk_modulus, shear_modulus):
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
        stress[k_row, 0] + (volumetric + 2.0 * shear_modulus * dxx),
        stress[k_row, 1] + (volumetric + 2.0 * shear_modulus * dyy),
        stress[k_row, 2] + volumetric,
        stress[k_row, 3] + 2.0 * shear_modulus * dxy,
    )


@kernel
def drucker_prager_update(stress, k_row, dxx, dyy, dxy, lame_lambda, shear_modulus, alpha, k_yield, alpha_psi):
    """Elastic trial and closed-form return of row k_row to f = alpha I1 + sqrt(J2) - k (in place).

    Flow g = sqrt(J2) + alpha_psi I1: d_eps_p = dlambda (s / (2 sqrt(J2)) + alpha_psi I), so
        s_new = s_tr - G dlambda s_tr / sqrt(J2_tr),  p_new = p_tr - 3 K alpha_psi dlambda,
        f_new = f_tr - dlambda (G + 9 K alpha alpha_psi) = 0.
    sqrt(J2_new) = sqrt(J2_tr) - G dlambda = k - 3 alpha p_new; if it is <= 0 (alpha > 0) the
    trial lies beyond the apex, i.e. G (p_tr - p_apex) >= 3 K alpha_psi sqrt(J2_tr), and
    sigma_new = p_apex I with p_apex = k / (3 alpha).
    Returns (equivalent plastic strain increment, plastic dissipation per volume in J/m^3).
    """
    g = shear_modulus
    bulk = lame_lambda + 2.0 * g / 3.0
    txx, tyy, tzz, txy = elastic_trial(stress, k_row, dxx, dyy, dxy, lame_lambda, g)
    p = (txx + tyy + tzz) / 3.0
    sxx = txx - p
    syy = tyy - p
    szz = tzz - p
    sqrt_j2 = math.sqrt(0.5 * (sxx * sxx + syy * syy + szz * szz) + txy * txy)
    pressure_term = 3.0 * alpha * p
    f = pressure_term + sqrt_j2 - k_yield
    if f <= YIELD_RTOL * (abs(p) + abs(pressure_term) + sqrt_j2 + k_yield):
        stress[k_row, 0] = txx
        stress[k_row, 1] = tyy
        stress[k_row, 2] = tzz
        stress[k_row, 3] = txy
        return 0.0, 0.0
    dlambda = f / (g + 9.0 * bulk * alpha * alpha_psi)
    p_new = p - 3.0 * bulk * alpha_psi * dlambda
    # sqrt(J2_new) = sqrt(J2_tr) - G dlambda, taken from f(sigma_new) = 0 itself so that the
    # returned state is on the surface to round-off relative to its own size
    sqrt_j2_new = k_yield - 3.0 * alpha * p_new
    if alpha > 0.0 and sqrt_j2_new <= 0.0:
        factor = 0.0  # apex (tension cut-off)
        p_new = k_yield / (3.0 * alpha)
    else:
        factor = sqrt_j2_new / sqrt_j2  # alpha = 0: sqrt(J2_new) = k >= 0
    nxx = p_new + factor * sxx
    nyy = p_new + factor * syy
    nzz = p_new + factor * szz
    nxy = factor * txy
    stress[k_row, 0] = nxx
    stress[k_row, 1] = nyy
    stress[k_row, 2] = nzz
    stress[k_row, 3] = nxy
    return _plastic_measures(txx - nxx, tyy - nyy, tzz - nzz, txy - nxy, nxx, nyy, nzz, nxy, bulk, g)


@kernel
def mohr_coulomb_update(stress, k_row, dxx, dyy, dxy, lame_lambda, shear_modulus, cohesion, sin_phi, cos_phi,
                        sin_psi):
    """Elastic trial and return of row k_row to Mohr-Coulomb in principal stresses (in place).

    Principal trial stresses: the in-plane pair c +- r from (xx, yy, xy) and zz, sorted
    s1 >= s2 >= s3.  Plane (i, j): f_ij = (s_i - s_j) + (s_i + s_j) sin(phi) - 2 c cos(phi),
    flow N_ij = (1 + sin psi) e_i - (1 - sin psi) e_j, D N = 2 K sin(psi) I + 2G (N - 2 sin(psi)/3 I);
    all planes share a = a_ij . D N_ij = 4G + 4 (G/3 + K) sin(phi) sin(psi).
    1. main plane (1, 3):  s = s_tr - dgamma D N_13,  dgamma = f_13 / a; valid if still sorted;
    2. else an edge, chosen by (1 - sin psi) s1 - 2 s2 + (1 + sin psi) s3 > 0 ? (s2 = s3, plane (1, 2))
       : (s1 = s2, plane (2, 3)); [a b; b a] dgamma = f with b = a_13 . D N_edge gives the new mean
       stress, which fixes the point on the edge line; valid if s1 >= s3;
    3. else the apex s1 = s2 = s3 = c cot(phi) (none for phi = 0, Tresca).
    The returned s1 - s3 is taken from f = 0 itself (on the surface to its own round-off).
    The new principal values go back to their own directions: the in-plane eigenvectors of
    the trial and e_z.  Returns (equivalent plastic strain increment, dissipation in J/m^3).
    """
    g = shear_modulus
    bulk = lame_lambda + 2.0 * g / 3.0
    txx, tyy, tzz, txy = elastic_trial(stress, k_row, dxx, dyy, dxy, lame_lambda, g)
    centre = 0.5 * (txx + tyy)
    half_diff = 0.5 * (txx - tyy)
    radius = math.sqrt(half_diff * half_diff + txy * txy)
    sa = centre + radius  # major in-plane
    sb = centre - radius  # minor in-plane
    if tzz >= sa:
        order = 0  # (zz, a, b)
        s1, s2, s3 = tzz, sa, sb
    elif tzz >= sb:
        order = 1  # (a, zz, b)
        s1, s2, s3 = sa, tzz, sb
    else:
        order = 2  # (a, b, zz)
        s1, s2, s3 = sa, sb, tzz
    two_c_cos = 2.0 * cohesion * cos_phi
    f = (s1 - s3) + (s1 + s3) * sin_phi - two_c_cos
    if f <= YIELD_RTOL * (abs(s1) + abs(s3) + two_c_cos):
        stress[k_row, 0] = txx
        stress[k_row, 1] = tyy
        stress[k_row, 2] = tzz
        stress[k_row, 3] = txy
        return 0.0, 0.0

    sin_prod = sin_phi * sin_psi
    a = 4.0 * g + 4.0 * (g / 3.0 + bulk) * sin_prod
    # 1. one-vector return to the main plane (1, 3): D N_13 = (n1, n2, n3) with
    #    n2 = 2 sin(psi) (K - 2G/3) and (n1 + n3) / 2 = 2 sin(psi) (K + G/3)
    dgamma = f / a
    r2 = s2 - dgamma * 2.0 * sin_psi * (bulk - 2.0 * g / 3.0)
    mid = 0.5 * (s1 + s3) - dgamma * 2.0 * sin_psi * (bulk + g / 3.0)
    spread = two_c_cos - 2.0 * mid * sin_phi  # s1 - s3 from f = 0: on the plane to round-off
    r1 = mid + 0.5 * spread
    r3 = mid - 0.5 * spread
    if not (r1 >= r2 and r2 >= r3):
        # 2. two-vector return to an edge.  The edge is a line, fixed by the new mean stress
        #    p_tr - 2 K sin(psi) (dgamma_a + dgamma_b), with dgamma_a + dgamma_b = (f_a + f_b) / (a + b)
        if (1.0 - sin_psi) * s1 - 2.0 * s2 + (1.0 + sin_psi) * s3 > 0.0:
            # right edge s2 = s3, second plane (1, 2)
            fb = (s1 - s2) + (s1 + s2) * sin_phi - two_c_cos
            b = 4.0 * bulk * sin_prod + 2.0 * g * (1.0 + sin_phi + sin_psi - sin_prod / 3.0)
            p_new = (s1 + s2 + s3) / 3.0 - 2.0 * bulk * sin_psi * (f + fb) / (a + b)
            # (s1, s2, s3) = (p + 2 delta, p - delta, p - delta) on f = 0
            delta = (two_c_cos - 2.0 * p_new * sin_phi) / (3.0 + sin_phi)
            r1 = p_new + 2.0 * delta
            r2 = p_new - delta
            r3 = r2
        else:
            # left edge s1 = s2, second plane (2, 3)
            fb = (s2 - s3) + (s2 + s3) * sin_phi - two_c_cos
            b = 4.0 * bulk * sin_prod + 2.0 * g * (1.0 - sin_phi - sin_psi - sin_prod / 3.0)
            p_new = (s1 + s2 + s3) / 3.0 - 2.0 * bulk * sin_psi * (f + fb) / (a + b)
            # (s1, s2, s3) = (p + delta, p + delta, p - 2 delta) on f = 0
            delta = (two_c_cos - 2.0 * p_new * sin_phi) / (3.0 - sin_phi)
            r1 = p_new + delta
            r2 = r1
            r3 = p_new - 2.0 * delta
        if delta < 0.0 and sin_phi > 0.0:
            # 3. apex (the edge return overshot it: s1 < s3)
            r1 = cohesion * cos_phi / sin_phi
            r2 = r1
            r3 = r1
    # back to (xx, yy, zz, xy) along the trial's principal directions
    if order == 0:
        na, nb, nz = r2, r3, r1
    elif order == 1:
        na, nb, nz = r1, r3, r2
    else:
        na, nb, nz = r1, r2, r3
    if radius > 0.0:
        cos_2t = half_diff / radius
        sin_2t = txy / radius
    else:
        cos_2t = 1.0
        sin_2t = 0.0
    new_centre = 0.5 * (na + nb)
    new_half = 0.5 * (na - nb)
    nxx = new_centre + new_half * cos_2t
    nyy = new_centre - new_half * cos_2t
    nxy = new_half * sin_2t
    stress[k_row, 0] = nxx
    stress[k_row, 1] = nyy
    stress[k_row, 2] = nz
    stress[k_row, 3] = nxy
    return _plastic_measures(s1 - r1, s2 - r2, s3 - r3, 0.0, r1, r2, r3, 0.0, bulk, g)


@kernel
def tension_cutoff(stress, k_row, mean_stress_cap, tensile_strength, lame_lambda, shear_modulus):
    """Tension cut-off of row k_row after its shear return (in place); sigma_t = ``tensile_strength``.

    ``mean_stress_cap`` (Drucker-Prager): p = I1 / 3 <= sigma_t, returned along I at fixed deviator
    (volumetric plastic flow, dp = (p - sigma_t)).  Otherwise (Mohr-Coulomb, Rankine): every
    principal stress s_i <= sigma_t, with plastic flow along the directions e_i of the active set A
    (the principal stresses held at sigma_t): for i in A
        s_i = s_i,tr - lambda sum_A dgamma - 2G dgamma_i = sigma_t,
    i.e. (lambda 1 1^T + 2G I) dgamma = s_A,tr - sigma_t, and the others lowered by lambda sum_A dgamma;
    A starts as the trial values above sigma_t, loses a member with dgamma < 0 and gains one left
    above sigma_t.  Both lower the shear yield function, so the state stays admissible.  Returns (equivalent plastic strain
    increment, dissipation in J/m^3) of the cut-off alone.
    """
    g = shear_modulus
    bulk = lame_lambda + 2.0 * g / 3.0
    sxx = stress[k_row, 0]
    syy = stress[k_row, 1]
    szz = stress[k_row, 2]
    sxy = stress[k_row, 3]
    if mean_stress_cap:
        mean = (sxx + syy + szz) / 3.0
        excess = mean - tensile_strength
        if excess <= YIELD_RTOL * (abs(mean) + abs(tensile_strength)):
            return 0.0, 0.0
        nxx, nyy, nzz, nxy = sxx - excess, syy - excess, szz - excess, sxy
    else:
        centre = 0.5 * (sxx + syy)
        half_diff = 0.5 * (sxx - syy)
        radius = math.sqrt(half_diff * half_diff + sxy * sxy)
        largest = max(centre + radius, szz)
        if largest - tensile_strength <= YIELD_RTOL * (abs(largest) + abs(tensile_strength) + radius):
            return 0.0, 0.0
        if radius > 0.0:
            cos_2t = half_diff / radius
            sin_2t = sxy / radius
        else:
            cos_2t = 1.0
            sin_2t = 0.0
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
        new_centre = 0.5 * (sa + sb)
        new_half = 0.5 * (sa - sb)
        nxx = new_centre + new_half * cos_2t
        nyy = new_centre - new_half * cos_2t
        nzz = sz
        nxy = new_half * sin_2t
    stress[k_row, 0] = nxx
    stress[k_row, 1] = nyy
    stress[k_row, 2] = nzz
    stress[k_row, 3] = nxy
    return _plastic_measures(sxx - nxx, syy - nyy, szz - nzz, sxy - nxy, nxx, nyy, nzz, nxy, bulk, g)
