"""Mohr-Coulomb, plane strain, perfectly plastic or strain-softening.

Return map in principal stresses (de Souza Neto, Peric & Owen 2008, sections 8.2-8.3, boxes
8.4-8.5), with s1 >= s2 >= s3:

    f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c cos(phi),    g = (s1 - s3) + (s1 + s3) sin(psi)

Properties: c, phi, psi and the tensile strength of an optional Rankine cut-off
(``tension_cutoff``), and strain softening: with eps the equivalent plastic strain, s(eps) the
share of the drop from peak to residual strength,

    linear       s = clip((eps - eps_1) / (eps_2 - eps_1), 0, 1)
    exponential  s = 1 - exp(-3 (eps - eps_1) / (eps_2 - eps_1)) above eps_1 (95% of the drop at eps_2)

c and phi move from peak to residual by s; psi stays as declared, at most phi.  Strength
reduction divides c, tan(phi), the residual c and tan(phi_r) and the tensile strength by F.
Conventions of the return map: ``return_map``.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.jit import inner_kernel, kernel
from spfem_core.materials.frictional import (
    FRICTIONAL_PROPERTIES,
    check_dilation,
    frictional_slip_strength,
    reduce_frictional,
    reduced_friction_deg,
)
from spfem_core.materials.properties import Property
from spfem_core.materials.return_map import (
    YIELD_RTOL,
    elastic_trial,
    plastic_measures,
    principal_direction,
    store_principal,
)
from spfem_core.state import XX, XY, YY, ZZ

NAME = "mohr_coulomb"
CODE = 2

SOFTENING_LAWS = ("none", "linear", "exponential")
"""Strain-softening laws (module doc), stored by their index: 0 none, 1 linear, 2 exponential."""
SOFTENING_NONE, SOFTENING_LINEAR, SOFTENING_EXPONENTIAL = range(len(SOFTENING_LAWS))

PROPERTIES = FRICTIONAL_PROPERTIES + (
    Property("softening_law", default=0.0, choices=SOFTENING_LAWS),
    Property("residual_cohesion_pa", default=math.nan, ge=0.0),  # NaN: the peak cohesion
    Property("residual_friction_deg", default=math.nan, ge=0.0, lt=90.0),  # NaN: the peak friction
    Property("softening_start_strain", default=0.0, ge=0.0),
    Property("softening_end_strain", default=math.nan, ge=0.0),  # needed with a softening law
)
"""c, phi, psi, the tensile strength, and the softening law with its residual strength and the
plastic strains where the drop starts and ends."""

CONSTANTS = ("cohesion_pa", "sin_phi", "cos_phi", "sin_psi", "tensile_strength_pa", "residual_cohesion_pa",
             "residual_friction_rad", "peak_friction_rad", "softening_start_strain", "softening_end_strain",
             "softening_law")
"""Named columns of the kernel constants."""
(COHESION, SIN_PHI, COS_PHI, SIN_PSI, TENSILE_STRENGTH, RESIDUAL_COHESION, RESIDUAL_FRICTION, PEAK_FRICTION,
 SOFTENING_START, SOFTENING_END, SOFTENING_LAW) = range(len(CONSTANTS))


def _residual(properties: dict) -> tuple[np.ndarray, np.ndarray]:
    """(residual c, residual phi): the peak values where none is given."""
    c_r, phi_r = properties["residual_cohesion_pa"], properties["residual_friction_deg"]
    return (np.where(np.isnan(c_r), properties["cohesion_pa"], c_r),
            np.where(np.isnan(phi_r), properties["friction_deg"], phi_r))


def check(properties: dict) -> str | None:
    """Why the rows' properties do not go together (psi <= phi; with softening, a residual strength
    at most the peak and 0 <= start < end), or None."""
    problem = check_dilation(properties)
    if problem:
        return problem
    softening = properties["softening_law"] != SOFTENING_NONE
    start, end = properties["softening_start_strain"], properties["softening_end_strain"]
    c_r, phi_r = _residual(properties)
    for rows, why in ((softening & ~(end > start), "softening_end_strain: must be > softening_start_strain"),
                      (softening & (c_r > properties["cohesion_pa"]), "residual_cohesion_pa: must be <= cohesion_pa"),
                      (softening & (phi_r > properties["friction_deg"]),
                       "residual_friction_deg: must be <= friction_deg")):
        if rows.any():
            return why
    return None


def constants(properties: dict, n_rows: int) -> tuple:
    """The columns of :data:`CONSTANTS` for ``n_rows`` rows (softening columns zero without a law)."""
    c, phi, psi = properties["cohesion_pa"], properties["friction_deg"], properties["dilation_deg"]
    law = properties["softening_law"]
    softening = law != SOFTENING_NONE
    c_r, phi_r = _residual(properties)

    def with_law(values):
        return np.where(softening, values, 0.0)

    return (c, np.sin(np.radians(phi)), np.cos(np.radians(phi)), np.sin(np.radians(psi)),
            properties["tensile_strength_pa"], with_law(c_r), with_law(np.radians(phi_r)), with_law(np.radians(phi)),
            with_law(properties["softening_start_strain"]), with_law(properties["softening_end_strain"]),
            with_law(law))


def reduced(properties: dict, srf: float, associated: bool) -> dict:
    """The peak strength reduced as ``frictional.reduce_frictional`` says, and the residual
    strength alike: c_r / F, tan(phi_r) / F (a residual strength not given follows the peak)."""
    reduced_peak = reduce_frictional(properties, srf, associated)
    return reduced_peak | {"residual_cohesion_pa": properties["residual_cohesion_pa"] / srf,
                           "residual_friction_deg": reduced_friction_deg(properties["residual_friction_deg"], srf)}


slip_strength = frictional_slip_strength
"""(c, tan phi) of a support the soil slides along (``frictional.frictional_slip_strength``)."""


@inner_kernel
def softened_strength(params, row, plastic_strain):
    """(c, sin phi, cos phi, sin psi) of softening row ``row`` at equivalent plastic strain
    ``plastic_strain``: c and phi move from peak to residual by the share s(eps) of the row's
    law (module doc); psi stays as declared, at most phi."""
    start = params[row, SOFTENING_START]
    span = params[row, SOFTENING_END] - start
    share = 0.0
    if plastic_strain > start:
        if params[row, SOFTENING_LAW] == SOFTENING_LINEAR:
            share = min((plastic_strain - start) / span, 1.0)
        else:
            share = 1.0 - math.exp(-3.0 * (plastic_strain - start) / span)
    cohesion = params[row, COHESION] + share * (params[row, RESIDUAL_COHESION] - params[row, COHESION])
    phi = params[row, PEAK_FRICTION] + share * (params[row, RESIDUAL_FRICTION] - params[row, PEAK_FRICTION])
    sin_phi = math.sin(phi)
    return cohesion, sin_phi, math.cos(phi), min(params[row, SIN_PSI], sin_phi)


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
        stress[k_row, XX] = txx
        stress[k_row, YY] = tyy
        stress[k_row, ZZ] = tzz
        stress[k_row, XY] = txy
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
    cos_2t, sin_2t = principal_direction(half_diff, txy, radius)
    store_principal(stress, k_row, na, nb, nz, cos_2t, sin_2t)
    return plastic_measures(s1 - r1, s2 - r2, s3 - r3, 0.0, r1, r2, r3, 0.0, bulk, g)

