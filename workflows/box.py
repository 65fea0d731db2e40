"""A box of the study file that selects particles by their initial position: ``[[boundary]]``
supports and ``[[seepage.boundary]]`` conditions.

Each bound is optional (a missing one leaves the box open on that side); the box is closed, with a
tolerance of h/1000 (as ``spfem_core.scene.Scene.select_box``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.fields import Record, StudyError, number

TOLERANCE_PER_SPACING = 1e-3


@dataclass(frozen=True, kw_only=True)
class Box(Record):
    """The four optional bounds of a box (m)."""

    x_min_m: float | None = number("m", "left side of the box; default: unbounded", default=None)
    x_max_m: float | None = number("m", "right side of the box; default: unbounded", default=None)
    y_min_m: float | None = number("m", "bottom of the box; default: unbounded", default=None)
    y_max_m: float | None = number("m", "top of the box; default: unbounded", default=None)

    def check(self):
        for axis in "xy":
            low, high = getattr(self, f"{axis}_min_m"), getattr(self, f"{axis}_max_m")
            if low is not None and high is not None and low > high:
                raise StudyError(f"{axis}_max_m", f"must be >= {axis}_min_m = {low:g}, got {high:g}")

    def holds(self, node_xy_m: np.ndarray, spacing_m: float) -> np.ndarray:
        """(n,) bool: the points inside the closed box (tolerance ``TOLERANCE_PER_SPACING`` h)."""
        tol = TOLERANCE_PER_SPACING * spacing_m
        inside = np.ones(node_xy_m.shape[0], dtype=bool)
        for axis, values in (("x", node_xy_m[:, 0]), ("y", node_xy_m[:, 1])):
            low, high = getattr(self, f"{axis}_min_m"), getattr(self, f"{axis}_max_m")
            inside &= (values >= (-np.inf if low is None else low) - tol) & (values <= (np.inf if high is None else high) + tol)
        return inside
