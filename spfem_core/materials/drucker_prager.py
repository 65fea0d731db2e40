"""Drucker-Prager, perfectly plastic, matched to Mohr-Coulomb (method notes, section 2).

    f = alpha I1 + sqrt(J2) - k (tension positive),    g = sqrt(J2) + alpha_psi I1

Properties: c, phi, psi of the Mohr-Coulomb soil it matches, the tensile strength of an optional
tension cut-off on the mean stress (``tension_cutoff``) and the fit (:data:`DP_FITS`; the default:
the plane-strain fit that reproduces Mohr-Coulomb at collapse for the dilation, :func:`default_dp_fit`).
Strength reduction divides c, tan(phi) and the tensile strength by F and recomputes alpha and k.
Conventions of the return map: ``return_map``.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.jit import kernel
from spfem_core.materials.frictional import (
    FRICTIONAL_PROPERTIES,
    check_dilation,
    frictional_slip_strength,
    reduce_frictional,
)
from spfem_core.materials.properties import Property
from spfem_core.materials.return_map import YIELD_RTOL, accept_trial, elastic_trial, plastic_measures
from spfem_core.state import XX, XY, YY, ZZ

NAME = "drucker_prager"
CODE = 1

DP_FITS = ("inner", "outer", "plane_strain_associated", "plane_strain_nonassociated")
"""Drucker-Prager matches to Mohr-Coulomb (method notes, section 2), see :func:`dp_constants`."""

PROPERTIES = FRICTIONAL_PROPERTIES + (Property("dp_fit", default=math.nan, choices=DP_FITS),)
"""c, phi, psi, the tensile strength, and the fit (NaN: :func:`default_dp_fit`)."""

CONSTANTS = ("alpha", "k_pa", "alpha_psi", "tensile_strength_pa")
"""Named columns of the kernel constants."""
ALPHA, K, ALPHA_PSI, TENSILE_STRENGTH = range(len(CONSTANTS))


def _cone_alpha(sin_angle, sign):
    """2 sin / (sqrt3 (3 + sign sin)): sign +1 inner (extension) cone, -1 outer (compression) cone."""
    return 2.0 * sin_angle / (math.sqrt(3.0) * (3.0 + sign * sin_angle))


def _plane_strain_alpha(tan_angle):
    """tan / sqrt(9 + 12 tan^2): the plane-strain match for associated flow."""
    return tan_angle / np.sqrt(9.0 + 12.0 * tan_angle * tan_angle)


def _check_strength(cohesion_pa, friction_deg, dilation_deg):
    for name, value in (("cohesion_pa", cohesion_pa), ("friction_deg", friction_deg),
                        ("dilation_deg", dilation_deg)):
        if not np.all(np.isfinite(value)):
            raise ValueError(f"{name}: must be a finite number, got {value}")
    if np.any(np.asarray(cohesion_pa) < 0.0):
        raise ValueError(f"cohesion_pa: must be >= 0, got {cohesion_pa}")
    if not np.all((0.0 <= np.asarray(friction_deg)) & (np.asarray(friction_deg) < 90.0)):
        raise ValueError(f"friction_deg: must be in [0, 90), got {friction_deg}")
    if not np.all((0.0 <= np.asarray(dilation_deg)) & (np.asarray(dilation_deg) <= friction_deg)):
        raise ValueError(f"dilation_deg: must be in [0, friction_deg = {friction_deg}], got {dilation_deg}")


def dp_constants(cohesion_pa, friction_deg, dilation_deg, fit: str):
    """Drucker-Prager (alpha, k in Pa, alpha_psi) matched to Mohr-Coulomb (c, phi, psi) by ``fit``,
    for numbers or arrays of them.

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
    constants = _fit_constants(np.asarray(cohesion_pa, dtype=np.float64), np.radians(friction_deg),
                               np.radians(dilation_deg), fit)
    if all(np.ndim(value) == 0 for value in (cohesion_pa, friction_deg, dilation_deg)):
        return tuple(float(value) for value in constants)  # numbers in, numbers out
    return constants


def _fit_constants(c, phi, psi, fit: str):
    """(alpha, k, alpha_psi) of :func:`dp_constants` from c and phi, psi in radians."""
    if fit in ("inner", "outer"):
        sign = 1.0 if fit == "inner" else -1.0
        alpha = _cone_alpha(np.sin(phi), sign)
        k = 6.0 * c * np.cos(phi) / (math.sqrt(3.0) * (3.0 + sign * np.sin(phi)))
        return alpha, k, _cone_alpha(np.sin(psi), sign)
    if fit == "plane_strain_associated":
        tan_phi = np.tan(phi)
        return (_plane_strain_alpha(tan_phi), 3.0 * c / np.sqrt(9.0 + 12.0 * tan_phi * tan_phi),
                _plane_strain_alpha(np.tan(psi)))
    if fit == "plane_strain_nonassociated":
        alpha_psi = _plane_strain_alpha(np.tan(psi))
        q = np.sqrt(1.0 - 3.0 * alpha_psi * alpha_psi)
        denominator = q * (3.0 + np.sin(phi) * np.sin(psi))
        return np.sin(phi) / denominator, 3.0 * c * np.cos(phi) / denominator, alpha_psi
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


def check(properties: dict) -> str | None:
    """Why the rows' properties do not go together (psi <= phi), or None."""
    return check_dilation(properties)


def constants(properties: dict, n_rows: int) -> tuple:
    """The columns of :data:`CONSTANTS` for ``n_rows`` rows: the fit of each row (its own, or the
    default for its dilation) applied to its c, phi and psi; rows grouped by fit."""
    c, phi, psi = properties["cohesion_pa"], properties["friction_deg"], properties["dilation_deg"]
    fit_code = properties["dp_fit"]
    associated = (psi > 0.0) & (psi == phi)
    default = np.where(associated, DP_FITS.index("plane_strain_associated"),
                       DP_FITS.index("plane_strain_nonassociated"))
    fit_code = np.where(np.isnan(fit_code), default, fit_code).astype(np.int64)
    alpha, k, alpha_psi = np.zeros(n_rows), np.zeros(n_rows), np.zeros(n_rows)
    for code in np.unique(fit_code):
        rows = fit_code == code
        alpha[rows], k[rows], alpha_psi[rows] = dp_constants(c[rows], phi[rows], psi[rows], DP_FITS[code])
    return alpha, k, alpha_psi, properties["tensile_strength_pa"]


def reduced(properties: dict, srf: float, associated: bool) -> dict:
    """c_F = c / F, tan(phi_F) = tan(phi) / F, psi_F = min(psi, phi_F) (= phi_F with ``associated``),
    sigma_t,F = sigma_t / F."""
    return reduce_frictional(properties, srf, associated)


slip_strength = frictional_slip_strength
"""(c, tan phi) of a support the soil slides along (``frictional.frictional_slip_strength``)."""


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
        return accept_trial(stress, k_row, txx, tyy, tzz, txy)
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
    stress[k_row, XX] = nxx
    stress[k_row, YY] = nyy
    stress[k_row, ZZ] = nzz
    stress[k_row, XY] = nxy
    return plastic_measures(txx - nxx, tyy - nyy, tzz - nzz, txy - nxy, nxx, nyy, nzz, nxy, bulk, g)

