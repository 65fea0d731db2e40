"""What the frictional models (``drucker_prager``, ``mohr_coulomb``) share: the Mohr-Coulomb
strength c, phi, psi with a tension cut-off, and what strength reduction does to it.

    c_F = c / F,   tan(phi_F) = tan(phi) / F,   psi_F = min(psi, phi_F)  (psi_F = phi_F when associated),
    sigma_t,F = sigma_t / F   (the tension cut-off falls with the cohesion)

``associated``: normality, the flow rule under which limit equilibrium and limit analysis give
the factor of safety.
"""

from __future__ import annotations

import math

import numpy as np

from spfem_core.materials.properties import Property

FRICTIONAL_PROPERTIES = (
    Property("cohesion_pa", ge=0.0),
    Property("friction_deg", ge=0.0, lt=90.0),
    Property("dilation_deg", default=0.0, ge=0.0, lt=90.0),
    Property("tensile_strength_pa", default=math.inf, ge=0.0, inf_allowed=True),
)
"""c (Pa), phi and psi (degrees, psi <= phi) and the tensile strength sigma_t (Pa; inf: no cut-off)."""


def reduced_friction_deg(friction_deg: np.ndarray, srf: float) -> np.ndarray:
    """phi_F = atan(tan(phi) / F) in degrees."""
    return np.degrees(np.arctan(np.tan(np.radians(friction_deg)) / srf))


def frictional_slip_strength(properties: dict, n_rows: int) -> tuple:
    """(c, tan phi): the Mohr-Coulomb strength tau = c + sigma_n tan(phi) of a support the soil
    slides along (its peak strength; a softening soil slides at its peak too)."""
    return properties["cohesion_pa"].copy(), np.tan(np.radians(properties["friction_deg"]))


def check_dilation(properties: dict) -> str | None:
    """Why the rows' dilation does not fit their friction (psi <= phi), or None."""
    psi, phi = properties["dilation_deg"], properties["friction_deg"]
    bad = np.flatnonzero(psi > phi)
    if bad.size:
        i = int(bad[0])
        return f"dilation_deg: must be <= friction_deg = {phi[i]:g}, got {psi[i]:g}"
    return None


def reduce_frictional(properties: dict, srf: float, associated: bool) -> dict:
    """The properties with the strength divided by ``srf`` (module doc)."""
    phi_f = reduced_friction_deg(properties["friction_deg"], srf)
    psi_f = phi_f if associated else np.minimum(properties["dilation_deg"], phi_f)
    return properties | {"cohesion_pa": properties["cohesion_pa"] / srf, "friction_deg": phi_f,
                         "dilation_deg": psi_f, "tensile_strength_pa": properties["tensile_strength_pa"] / srf}
