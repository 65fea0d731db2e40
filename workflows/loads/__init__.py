"""``[loads]``: gravity and the loads of a study, one module per kind of load.

- body forces: gravity (``gravity_m_s2``) and the pseudo-static earthquake (``seismic``);
- surface loads on the upper surface of the cloud (``surface``): ``strip`` and ``line``, the kinds
  of :data:`SURFACE_LOADS`.  Each declares its table, the fields that must lie on the ground
  (``abscissae_m``), its nodal forces (``add_forces``) and what the figures draw (``arrows_m``);
  the study, the scene and the figures loop over them.  Adding a kind: docs/architecture.md.

Water is not a load here: ``workflows.water``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from workflows.fields import Record, StudyError, number, optional_table, point, tables
from workflows.loads.line import LineLoad
from workflows.loads.seismic import Seismic
from workflows.loads.strip import StripLoad

SURFACE_LOADS = {"strip": StripLoad, "line": LineLoad}
"""Every kind of surface load: the field of ``[loads]`` that lists them, and its table."""


@dataclass(frozen=True, kw_only=True)
class Loads(Record):
    """Body forces and surface loads, applied from the start of the first stage (the seismic load:
    see [loads.seismic])."""

    gravity_m_s2: tuple = point("m s-2", "gravitational acceleration [gx, gy]", default=(0.0, -9.81))
    seismic: Seismic | None = optional_table(Seismic)
    strip: tuple = tables(StripLoad, "uniform pressures on the ground surface")
    line: tuple = tables(LineLoad, "point forces on the ground surface")
    ramp_time_s: float | None = number(
        "s", "the strip and line loads grow linearly from zero over this time at the start of the first stage "
        "(a relaxation does not converge before it ends); default: applied at once", default=None, gt=0.0,
    )

    def check_in_study(self, study) -> None:
        """StudyError on a surface load off the ground surface, a ramp longer than the first stage, or a
        seismic load for strength-reduction runs in a study that has none."""
        xs = [x for x, _ in study.geometry.polygon_m]
        x_min, x_max = min(xs), max(xs)
        for where, load in self.surface_loads():
            for field, x in load.abscissae_m().items():
                if not x_min <= x <= x_max:
                    raise StudyError(f"{where}.{field}", f"{x:g} m is off the ground surface, which spans "
                                     f"x = {x_min:g} to {x_max:g} m")
        first = study.stages[0]
        if self.ramp_time_s is not None and self.ramp_time_s > first.time_limit_s:
            raise StudyError("loads.ramp_time_s", f"must be <= the first stage's {first.duration_field} = "
                             f"{first.time_limit_s:g}, got {self.ramp_time_s:g}")
        if self.seismic is not None and not self.seismic.in_gravity and study.strength_reduction is None:
            raise StudyError("loads.seismic.in_gravity", "false applies the load in strength-reduction runs only, "
                             "and this study has none")

    def surface_loads(self):
        """(field path, load) of every surface load, kind by kind in :data:`SURFACE_LOADS` order, in
        file order within a kind."""
        return [(f"loads.{kind}[{i}]", load) for kind in SURFACE_LOADS for i, load in enumerate(getattr(self, kind))]

    def acceleration_m_s2(self, polygon_m, strength_reduction: bool) -> np.ndarray:
        """Gravity plus the pseudo-static seismic acceleration where it acts: in strength-reduction
        runs, and in the stages before them with ``in_gravity`` (``polygon_m``: the domain, whose
        downslope side ``out_of_slope`` means)."""
        seismic = self.seismic
        if seismic is None or not (strength_reduction or seismic.in_gravity):
            return np.array(self.gravity_m_s2, dtype=np.float64)
        return seismic.acceleration_m_s2(self.gravity_m_s2, polygon_m)


__all__ = ["SURFACE_LOADS", "LineLoad", "Loads", "Seismic", "StripLoad"]
