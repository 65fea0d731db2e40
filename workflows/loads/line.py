"""``[[loads.line]]``: a vertical force F (per metre of thickness) at one abscissa of the ground surface.

F goes to the two particles of the first upper-surface edge above x (``surface.UpperSurface``),
shared by their linear shape functions: f_a = -F (x - x_b) / (x_a - x_b), f_b = -F - f_a (downward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.fields import Record, StudyError, name_field, number


@dataclass(frozen=True, kw_only=True)
class LineLoad(Record):
    """A vertical force at one point of the ground surface (per metre of thickness), carried by the
    surface particles there from the first stage on."""

    name: str = name_field("name of the load")
    x_m: float = number("m", "abscissa of the point on the ground surface")
    force_n_m: float = number("N m-1", "force, downward, per metre of out-of-plane thickness", gt=0.0)

    def abscissae_m(self) -> dict[str, float]:
        """The fields that must lie on the ground surface, by name."""
        return {"x_m": self.x_m}

    def add_forces(self, surface, force_n: np.ndarray, where: str) -> None:
        """Add the load's nodal forces (module doc) to ``force_n`` (n, 2), N/m; StudyError naming
        ``where`` when no edge of the surface lies above x."""
        xa, xb = surface.x_a_m, surface.x_b_m
        holding = np.flatnonzero((xb <= self.x_m) & (self.x_m <= xa))
        if holding.size == 0:
            raise StudyError(f"{where}.x_m", f"{self.x_m:g} m: no ground surface above this abscissa")
        e = holding[0]
        share_a = (self.x_m - xb[e]) / (xa[e] - xb[e])
        force_n[surface.edges[e, 0], 1] -= self.force_n_m * share_a
        force_n[surface.edges[e, 1], 1] -= self.force_n_m * (1.0 - share_a)

    def arrows_m(self) -> np.ndarray:
        """Abscissae of the arrows the figures draw."""
        return np.array([self.x_m])
