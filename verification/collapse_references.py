"""Reference values of the two column collapses, and the pass bands the verification uses.

Coordinates: wall at x = 0, base at y = 0, the column occupies 0 <= x <= L0, 0 <= y <= H0
(``shared/reference/collapse_refs.md``).

Granular column, L0 = 0.2 m, H0 = 0.1 m (Bui et al. 2008): metrics derived from the digitised
experiment (``workflows.collapse.experiment``) and the bands of the verification.

Cohesive column, L0 = 4 m, H0 = 2 m (Bui et al. 2008, Chalk et al. 2020): no published final
profile; the anchors are closed-form (Rankine / Culmann) functions of the cohesion c, the
friction angle phi and the unit weight gamma = rho g.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

GRANULAR_WALL_HEIGHT_M = 0.0992
"""Derived: final surface height at the wall (the top-left corner does not move)."""
GRANULAR_RUNOUT_BY_THICKNESS_M = {0.002: 0.429, 0.005: 0.396, 0.010: 0.368}
"""Derived: runout (m) where the deposit thins to the key thickness (m)."""
GRANULAR_SURFACE_SLOPE_DEG = 16.0
"""Derived: surface slope over x = 0.02-0.20 m, about 16 deg."""
GRANULAR_FAILURE_LINE_ANGLE_DEG = 33.0
GRANULAR_FAILURE_LINE_BASE_X_M = 0.179


@dataclass(frozen=True)
class GranularPassBands:
    """Pass bands of the granular column against the experiment (collapse_refs.md).

    Each band is an inclusive (low, high) interval of the summary key of the same name
    (see :func:`workflows.collapse.metrics.granular_summary`).
    """

    final_wall_height_m: tuple[float, float] = (0.095, 0.100)
    runout_2mm_m: tuple[float, float] = (0.39, 0.47)
    surface_rms_error_m: tuple[float, float] = (0.0, 0.005)
    failure_line_angle_deg: tuple[float, float] = (28.0, 38.0)
    failure_line_base_x_m: tuple[float, float] = (0.16, 0.20)

    def bands(self) -> dict[str, tuple[float, float]]:
        """The bands as {summary key: (low, high)}."""
        return {name: getattr(self, name) for name in self.__dataclass_fields__}

    def failures(self, summary: dict[str, float]) -> list[str]:
        """Messages for every summary value outside its band (a missing or NaN value fails)."""
        messages = []
        for key, (low, high) in self.bands().items():
            value = summary.get(key, math.nan)
            if not (low <= value <= high):
                messages.append(f"{key} = {value:.6g} outside [{low:g}, {high:g}]")
        return messages


GRANULAR_PASS_BANDS = GranularPassBands()

# --------------------------------------------------------------------------------------
# Cohesive column
# --------------------------------------------------------------------------------------

COHESIVE_COLUMN_WIDTH_M = 4.0
COHESIVE_COLUMN_HEIGHT_M = 2.0
COHESIVE_DENSITY_KG_M3 = 1850.0
COHESIVE_GRAVITY_M_S2 = 9.81
COHESIVE_COHESION_PA = 5.0e3
COHESIVE_FRICTION_ANGLE_DEG = 25.0
COHESIVE_BACK_SCARP_BAND_M = (2.6, 3.0)
"""Back scarp of the failed block in the initial configuration expected around x = 2.6-3.0 m."""


def passive_coefficient(friction_angle_deg: float) -> float:
    """Rankine passive coefficient Kp = tan^2(45 deg + phi/2) = (1 + sin phi)/(1 - sin phi)."""
    return math.tan(math.radians(45.0 + 0.5 * friction_angle_deg)) ** 2


def critical_cut_height_m(cohesion_pa: float, friction_angle_deg: float, unit_weight_n_m3: float) -> float:
    """Critical height of an unsupported vertical cut, Hc = 4 c sqrt(Kp) / gamma."""
    return 4.0 * cohesion_pa * math.sqrt(passive_coefficient(friction_angle_deg)) / unit_weight_n_m3


def tension_crack_depth_m(cohesion_pa: float, friction_angle_deg: float, unit_weight_n_m3: float) -> float:
    """Rankine tension-crack depth, z0 = 2 c sqrt(Kp) / gamma (half the critical cut height)."""
    return 2.0 * cohesion_pa * math.sqrt(passive_coefficient(friction_angle_deg)) / unit_weight_n_m3


def culmann_angle_deg(friction_angle_deg: float) -> float:
    """Inclination from horizontal of the Culmann failure plane through the toe, 45 deg + phi/2."""
    return 45.0 + 0.5 * friction_angle_deg


def culmann_top_x_m(friction_angle_deg: float, height_m: float, toe_x_m: float) -> float:
    """Where the Culmann plane through the toe (x = L0, y = 0) reaches the top y = H:
    x_top = L0 - H / tan(45 deg + phi/2)."""
    return toe_x_m - height_m / math.tan(math.radians(culmann_angle_deg(friction_angle_deg)))
