"""``[[loads.strip]]``: a uniform vertical pressure q on the ground surface between x1 and x2.

On an upper-surface edge (``surface.UpperSurface``) the load is q times the edge's overlap
[lo, hi] with [x1, x2], shared by its particles as int_lo^hi N_a dx and int_lo^hi N_b dx with
N_a = (x - x_b) / (x_a - x_b):

    f_a = -q ((hi - x_b)^2 - (lo - x_b)^2) / (2 (x_a - x_b)),    f_b = -q (hi - lo) - f_a    (downward)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.fields import Record, StudyError, name_field, number

ARROWS_PER_STRIP = 5
"""Arrows drawn over a strip in the figures."""


@dataclass(frozen=True, kw_only=True)
class StripLoad(Record):
    """A uniform vertical pressure on the ground surface between two abscissae (a footing, a surcharge),
    carried by the surface particles from the first stage on."""

    name: str = name_field("name of the load")
    x_start_m: float = number("m", "left end of the loaded strip")
    x_end_m: float = number("m", "right end of the loaded strip")
    pressure_pa: float = number("Pa", "pressure q, downward, per metre of horizontal length", gt=0.0)

    def check(self):
        if not self.x_end_m > self.x_start_m:
            raise StudyError("x_end_m", f"must be > x_start_m = {self.x_start_m:g}, got {self.x_end_m:g}")

    def abscissae_m(self) -> dict[str, float]:
        """The fields that must lie on the ground surface, by name."""
        return {"x_start_m": self.x_start_m, "x_end_m": self.x_end_m}

    def add_forces(self, surface, force_n: np.ndarray, where: str) -> None:
        """Add the load's nodal forces (module doc) to ``force_n`` (n, 2), N/m; StudyError naming
        ``where`` when the strip reaches no edge of the surface."""
        xa, xb = surface.x_a_m, surface.x_b_m
        lo = np.clip(self.x_start_m, xb, xa)
        hi = np.clip(self.x_end_m, xb, xa)
        on_a = ((hi - xb) ** 2 - (lo - xb) ** 2) / (2.0 * (xa - xb))
        on_b = (hi - lo) - on_a
        if not np.any(hi > lo):
            raise StudyError(where, f"{self.name!r} reaches no particle of the ground surface")
        np.add.at(force_n[:, 1], surface.edges[:, 0], -self.pressure_pa * on_a)
        np.add.at(force_n[:, 1], surface.edges[:, 1], -self.pressure_pa * on_b)

    def arrows_m(self) -> np.ndarray:
        """Abscissae of the arrows the figures draw."""
        return np.linspace(self.x_start_m, self.x_end_m, ARROWS_PER_STRIP)
