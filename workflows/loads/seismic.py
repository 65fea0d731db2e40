"""``[loads.seismic]``: a pseudo-static earthquake, the body force kh g horizontally and kv g vertically.

    a = g_vec + (s kh |g|, kv |g|),    s = +1 or -1, the direction of the horizontal force

``out_of_slope`` points it towards the side where the ground surface is lower (the free face,
``spfem_core.geometry.downslope_sign``).  By default it acts from the first stage on (every SRF run
starts in equilibrium with it); with ``in_gravity = false`` only in the strength-reduction runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import downslope_sign
from workflows.fields import Record, StudyError, boolean, number, text

OUT_OF_SLOPE = "out_of_slope"


@dataclass(frozen=True, kw_only=True)
class Seismic(Record):
    """Pseudo-static earthquake load: body forces kh g horizontally and kv g vertically (g = |gravity|),
    from the first stage on (or in the strength-reduction runs only)."""

    horizontal_coefficient: float = number("1", "kh: horizontal body force kh g per unit mass, towards direction",
                                           ge=0.0, lt=1.0)
    vertical_coefficient: float = number(
        "1", "kv: vertical body force kv g per unit mass, upward for kv > 0 (the soil weighs (1 - kv) g), downward "
        "for kv < 0", default=0.0, gt=-1.0, lt=1.0,
    )
    direction: str = text(
        "direction of the horizontal force: `out_of_slope` (towards the side where the ground surface is lower, "
        "the free face), `+x` or `-x`", default=OUT_OF_SLOPE, choices=(OUT_OF_SLOPE, "+x", "-x"),
    )
    in_gravity: bool = boolean(
        "apply it in the stages before the strength reduction too, so that every SRF run starts in equilibrium "
        "with it and moves by the strength reduction alone; false: only in the SRF runs, which then also carry "
        "the elastic response to the load suddenly applied", default=True,
    )

    def acceleration_m_s2(self, gravity_m_s2, polygon_m) -> np.ndarray:
        """g_vec plus the seismic part (module doc), the horizontal sign from :func:`horizontal_sign`."""
        return with_horizontal(gravity_m_s2, self.horizontal_coefficient, horizontal_sign(self.direction, polygon_m),
                               self.vertical_coefficient)

    def note(self) -> str:
        """The figure's note of the load."""
        return f"kh = {self.horizontal_coefficient:g}, kv = {self.vertical_coefficient:g}"


def horizontal_sign(direction: str, polygon_m) -> float:
    """+1 or -1: the x direction of the horizontal force; ``out_of_slope`` is the downslope side of
    the domain's ground surface (StudyError where both ends are as high)."""
    if direction != OUT_OF_SLOPE:
        return 1.0 if direction == "+x" else -1.0
    sign = downslope_sign(polygon_m)
    if sign is None:
        raise StudyError("loads.seismic.direction", "the ground surface is as high at both ends of the domain, so "
                         "out_of_slope has no meaning here: give +x or -x")
    return sign


def with_horizontal(gravity_m_s2, kh: float, sign: float, kv: float = 0.0) -> np.ndarray:
    """g_vec + (sign kh |g|, kv |g|) (m/s^2)."""
    gravity = np.array(gravity_m_s2, dtype=np.float64)
    g = float(np.hypot(*gravity))
    return gravity + np.array([sign * kh * g, kv * g])
