"""The factor of safety as h -> 0 from its values at three spacings: Richardson extrapolation and
Roache's grid convergence index (GCI), by the procedure of Celik et al. (2008), "Procedure for
estimation and reporting of uncertainty due to discretization in CFD applications", J. Fluids
Eng. 130(7), 078001 (ASME V&V 20).

With h1 < h2 < h3 (finest first), f_i the FOS at h_i, r21 = h2 / h1, r32 = h3 / h2,
e21 = f2 - f1, e32 = f3 - f2 and s = sign(e32 / e21), the observed order p solves

    p = | ln|e32 / e21| + q(p) | / ln r21,      q(p) = ln((r21^p - s) / (r32^p - s))

(fixed-point iteration from q = 0; q = 0 exactly for a constant ratio), and

    f_ext    = (r21^p f1 - f2) / (r21^p - 1)                 (Richardson, h -> 0)
    GCI_fine = Fs |e21| / (r21^p - 1)                         (Fs = 1.25 for three levels)

the uncertainty of f1, so that f_ext lies in f1 -+ GCI_fine.  Where the levels do not extrapolate,
:func:`extrapolate` says why and gives a conservative band instead (``Extrapolation.status``):

- ``converged``: the two differences are within the levels' own resolution (the FOS brackets'
  half-widths): f1 with a band of the largest difference and the resolution;
- ``oscillating``: s < 0; ``order_out_of_range``: p outside [P_MIN, P_MAX]; then Roache's
  conservative estimate for an unreliable order, Fs = 3 at p = 1: f1 -+ 3 |e21| / (r21 - 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

SAFETY_FACTOR = 1.25
"""Fs of the GCI with three levels and an order that agrees with theory (Roache)."""
CONSERVATIVE_SAFETY_FACTOR = 3.0
"""Fs where the observed order is not to be trusted (two levels, oscillation, an order out of range)."""
P_MIN, P_MAX = 0.5, 4.0
"""Orders outside this range are not a convergence rate of a first-order method: no extrapolation."""
EXTRAPOLATED, CONVERGED, OSCILLATING, ORDER_OUT_OF_RANGE = "extrapolated", "converged", "oscillating", \
    "order_out_of_range"


@dataclass(frozen=True)
class Extrapolation:
    """The FOS as h -> 0 and its band."""

    status: str  # EXTRAPOLATED, CONVERGED, OSCILLATING or ORDER_OUT_OF_RANGE
    fos: float  # Richardson's f_ext when extrapolated, else the finest level's FOS
    band_low: float  # the FOS lies in [band_low, band_high] with the stated confidence
    band_high: float
    observed_order: float  # p (NaN where none)
    gci: float  # GCI_fine as a fraction of f1 (where extrapolated), else the band's half-width / f1
    reason: str  # one line

    @property
    def uncertainty(self) -> float:
        """Half-width of the band."""
        return 0.5 * (self.band_high - self.band_low)


def observed_order(r21: float, r32: float, e21: float, e32: float, iterations: int = 100) -> float:
    """p of the module doc (NaN if the fixed point does not settle)."""
    s = math.copysign(1.0, e32 / e21)
    ratio = abs(e32 / e21)
    p = abs(math.log(ratio)) / math.log(r21)  # q = 0
    for _ in range(iterations):
        inside = (r21**p - s) / (r32**p - s)
        if not inside > 0:
            return math.nan
        new = abs(math.log(ratio) + math.log(inside)) / math.log(r21)
        if abs(new - p) < 1e-12:
            return new
        p = new
    return math.nan


def extrapolate(spacings_m, fos, resolution: float, safety_factor: float = SAFETY_FACTOR) -> Extrapolation:
    """The extrapolation of the three finest levels (module doc).  ``spacings_m``, ``fos``: one value
    per level in any order; ``resolution``: how far a level's FOS may lie from its own converged
    value by the search alone (half the width of its FOS bracket)."""
    if len(spacings_m) != len(fos) or len(fos) < 3:
        raise ValueError("extrapolate: at least three levels with an FOS each")
    (h1, f1), (h2, f2), (h3, f3) = sorted(zip(spacings_m, fos))[:3]
    r21, r32, e21, e32 = h2 / h1, h3 / h2, f2 - f1, f3 - f2

    def band(half: float) -> tuple[float, float]:
        return f1 - half, f1 + half

    if max(abs(e21), abs(e32)) <= 2.0 * resolution:
        half = max(abs(e21), abs(e32), resolution)
        return Extrapolation(CONVERGED, f1, *band(half), math.nan, half / f1,
                             f"the levels agree within their search resolution ({e21:+.4f}, {e32:+.4f} between levels, "
                             f"+-{resolution:.4f} each): no order to observe; the band is the largest difference")
    conservative = CONSERVATIVE_SAFETY_FACTOR * abs(e21) / (r21 - 1.0)
    if e21 == 0.0 or e32 / e21 < 0.0:
        return Extrapolation(OSCILLATING, f1, *band(conservative), math.nan, conservative / f1,
                             f"the FOS does not change monotonically with h ({f3:.4f}, {f2:.4f}, {f1:.4f}): not "
                             f"extrapolated; conservative band Fs = {CONSERVATIVE_SAFETY_FACTOR:g} at p = 1")
    p = observed_order(r21, r32, e21, e32)
    if not P_MIN <= p <= P_MAX:
        return Extrapolation(ORDER_OUT_OF_RANGE, f1, *band(conservative), p, conservative / f1,
                             f"observed order {p:.3g} outside [{P_MIN:g}, {P_MAX:g}]: not extrapolated; conservative "
                             f"band Fs = {CONSERVATIVE_SAFETY_FACTOR:g} at p = 1")
    extrapolated = (r21**p * f1 - f2) / (r21**p - 1.0)
    gci = safety_factor * abs(e21) / (r21**p - 1.0)
    return Extrapolation(EXTRAPOLATED, extrapolated, *band(gci), p, gci / f1,
                         f"observed order {p:.3g}; Richardson's FOS at h -> 0 is {extrapolated:.4f}; GCI "
                         f"(Fs = {safety_factor:g}) {100 * gci / f1:.2g}% of the finest level's {f1:.4f}")
