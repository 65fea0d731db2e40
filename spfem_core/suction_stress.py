"""The suction stress of an unsaturated soil (Lu & Likos 2006): what the pore water adds to the
effective stress above the water table.

Bishop's effective stress with chi = S_e, written with the suction stress sigma_s (Pa):

    sigma' = (sigma - u_a) - sigma_s,        sigma_s = -S_e(psi) (u_a - u_w),

stresses positive in compression, the pore air at atmospheric pressure (u_a = 0) and the pore
water at u_w = gamma_w psi.  Then sigma_s = S_e(psi) gamma_w psi at every pressure head: below the
water table S_e = 1 and sigma_s = u_w, Terzaghi's effective stress; above it sigma_s < 0, a tension
of the water that presses the grains together, which vanishes both at saturation (psi -> 0) and in
dry soil (S_e -> 0).  Lu & Likos's closed form for van Genuchten's curve (with its own alpha and n
in pressure units) is the same expression with S_e substituted; any curve of
``spfem_core.soil_water`` gives S_e.  Why this form is the one the engine is to use (rather than
Fredlund's phi_b): docs/method.md, "Transient unsaturated seepage".
"""

from __future__ import annotations

import numpy as np

from spfem_core.soil_water import SoilWaterCurve


def suction_stress_pa(curve: SoilWaterCurve, pressure_head_m, water_unit_weight_n_m3: float = 9810.0) -> np.ndarray:
    """sigma_s = S_e(psi) gamma_w psi (Pa; < 0 above the water table, = u_w below it)."""
    psi = np.asarray(pressure_head_m, dtype=float)
    return curve.effective_saturation(psi) * water_unit_weight_n_m3 * psi
