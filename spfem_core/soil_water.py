"""Soil-water characteristic curves: how much water a soil holds, and how well it conducts, at a
pressure head psi (m; negative: suction).  Plain numpy; every function takes and returns arrays.

For a curve with residual and saturated water contents theta_r, theta_s, the effective
saturation S_e(psi) in [0, 1] gives

    theta(psi) = theta_r + (theta_s - theta_r) S_e(psi),
    C(psi)     = d theta / d psi = (theta_s - theta_r) dS_e / dpsi     (the specific moisture capacity, 1/m),

and the relative conductivity k_r(psi) in [0, 1] scales the saturated conductivity tensor:
K(psi) = k_r(psi) K_sat.  At psi >= 0 every curve is saturated: S_e = 1, k_r = 1, C = 0; there the
water a soil stores changes through its specific storage S_s (1/m) alone, the term S_s S_e dpsi/dt
of Richards' equation (``spfem_core.transient_seepage``).

- **van Genuchten (1980)** with Mualem's (1976) conductivity, m = 1 - 1/n (n > 1), x = (alpha |psi|)^n:

      S_e = (1 + x)^(-m),
      dS_e/dpsi = m n alpha (alpha |psi|)^(n-1) (1 + x)^(-m-1)                          (psi < 0),
      k_r = S_e^(1/2) [1 - (1 - S_e^(1/m))^m]^2 = S_e^(1/2) [1 - (x / (1 + x))^m]^2.

  The last form is evaluated as written (1 - S_e^(1/m) = x / (1 + x) exactly, so no cancellation
  near saturation) and 1 - (x / (1 + x))^m as -expm1(m ln(x / (1 + x))), the logarithm as
  -log1p(1 / x) for x >= 1 (no cancellation in the dry range either).
- **Gardner's exponential model** (1958), the one with closed-form solutions of Richards' equation
  (Srivastava & Yeh 1991; Lu & Griffiths 2004): S_e = k_r = exp(a psi), dS_e/dpsi = a exp(a psi)
  for psi < 0.  Its capacity jumps from (theta_s - theta_r) a to 0 at psi = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


def _check_contents(residual: float, saturated: float, specific_storage_1_m: float) -> None:
    if not (math.isfinite(residual) and math.isfinite(saturated) and 0.0 <= residual < saturated <= 1.0):
        raise ValueError(f"water contents: need 0 <= theta_r < theta_s <= 1, got theta_r = {residual!r}, "
                         f"theta_s = {saturated!r}")
    if not (math.isfinite(specific_storage_1_m) and specific_storage_1_m >= 0.0):
        raise ValueError(f"specific storage: need a finite S_s >= 0 (1/m), got {specific_storage_1_m!r}")


class CurveValues(NamedTuple):
    """A curve's four values at the same pressure heads (arrays)."""

    effective_saturation: np.ndarray
    water_content: np.ndarray
    moisture_capacity_1_m: np.ndarray
    relative_conductivity: np.ndarray


class _Curve:
    """theta and C from S_e and dS_e/dpsi (module doc)."""

    residual_water_content: float
    saturated_water_content: float

    def values(self, pressure_head_m) -> CurveValues:
        """S_e, theta, C and k_r at once (what the transient solver needs every iteration; the same numbers as
        the four functions)."""
        psi = np.asarray(pressure_head_m, dtype=float)
        return CurveValues(self.effective_saturation(psi), self.water_content(psi), self.moisture_capacity_1_m(psi),
                           self.relative_conductivity(psi))

    def water_content(self, pressure_head_m) -> np.ndarray:
        """theta(psi) = theta_r + (theta_s - theta_r) S_e(psi)."""
        return self.residual_water_content + (self.saturated_water_content - self.residual_water_content) * (
            self.effective_saturation(pressure_head_m))

    def moisture_capacity_1_m(self, pressure_head_m) -> np.ndarray:
        """C(psi) = d theta / d psi = (theta_s - theta_r) dS_e/dpsi (1/m); 0 at psi >= 0."""
        return (self.saturated_water_content - self.residual_water_content) * self._saturation_slope_1_m(
            np.asarray(pressure_head_m, dtype=float))


@dataclass(frozen=True)
class VanGenuchten(_Curve):
    """van Genuchten's (1980) curve with Mualem's conductivity (module doc)."""

    residual_water_content: float  # theta_r
    saturated_water_content: float  # theta_s
    alpha_1_m: float  # alpha (1/m): about the inverse of the air-entry head
    n: float  # > 1; m = 1 - 1/n
    specific_storage_1_m: float = 0.0  # S_s

    def __post_init__(self):
        _check_contents(self.residual_water_content, self.saturated_water_content, self.specific_storage_1_m)
        if not (math.isfinite(self.alpha_1_m) and self.alpha_1_m > 0.0):
            raise ValueError(f"van Genuchten alpha: need a finite alpha > 0 (1/m), got {self.alpha_1_m!r}")
        if not (math.isfinite(self.n) and self.n > 1.0):
            raise ValueError(f"van Genuchten n: need a finite n > 1, got {self.n!r}")

    @property
    def m(self) -> float:
        """m = 1 - 1/n."""
        return 1.0 - 1.0 / self.n

    def _x(self, psi: np.ndarray) -> np.ndarray:
        """x = (alpha |psi|)^n at psi < 0, 0 above; +inf beyond the largest float (the curves' dry limit)."""
        with np.errstate(over="ignore"):
            return (self.alpha_1_m * np.maximum(-psi, 0.0)) ** self.n

    def effective_saturation(self, pressure_head_m) -> np.ndarray:
        """S_e = (1 + (alpha |psi|)^n)^(-m) for psi < 0, 1 above."""
        return (1.0 + self._x(np.asarray(pressure_head_m, dtype=float))) ** -self.m

    def _slope(self, psi: np.ndarray, x: np.ndarray, se: np.ndarray) -> np.ndarray:
        # m n alpha (alpha |psi|)^(n-1) (1 + x)^(-m-1) = m n alpha [x / (1 + x)] (1 + x)^(-m) / (alpha |psi|)
        suction = self.alpha_1_m * np.maximum(-psi, 0.0)
        small = np.minimum(x, 1.0)
        ratio = np.where(x > 1.0, 1.0 / (1.0 + 1.0 / np.maximum(x, 1.0)), small / (1.0 + small))  # x / (1 + x)
        return np.where(suction > 0.0, self.m * self.n * self.alpha_1_m * ratio * se
                        / np.where(suction > 0.0, suction, 1.0), 0.0)

    def _saturation_slope_1_m(self, psi: np.ndarray) -> np.ndarray:
        x = self._x(psi)
        return self._slope(psi, x, (1.0 + x) ** -self.m)

    def _conductivity(self, x: np.ndarray, se: np.ndarray) -> np.ndarray:
        large, small = np.maximum(x, 1.0), np.where(x > 0.0, np.minimum(x, 1.0), 1.0)
        log_ratio = np.where(x >= 1.0, -np.log1p(1.0 / large), np.log(small) - np.log1p(small))  # ln(x / (1 + x))
        tail = np.where(x > 0.0, -np.expm1(self.m * log_ratio), 1.0)  # 1 - (x / (1 + x))^m
        return np.sqrt(se) * tail * tail

    def relative_conductivity(self, pressure_head_m) -> np.ndarray:
        """k_r = S_e^(1/2) [1 - (x / (1 + x))^m]^2, x = (alpha |psi|)^n (Mualem; module doc)."""
        x = self._x(np.asarray(pressure_head_m, dtype=float))
        return self._conductivity(x, (1.0 + x) ** -self.m)

    def values(self, pressure_head_m) -> CurveValues:
        """S_e, theta, C and k_r at once, x and S_e computed once."""
        psi = np.asarray(pressure_head_m, dtype=float)
        x = self._x(psi)
        se = (1.0 + x) ** -self.m
        span = self.saturated_water_content - self.residual_water_content
        return CurveValues(se, self.residual_water_content + span * se, span * self._slope(psi, x, se),
                           self._conductivity(x, se))


@dataclass(frozen=True)
class Gardner(_Curve):
    """Gardner's exponential curve: S_e = k_r = exp(a psi) for psi < 0 (module doc)."""

    residual_water_content: float  # theta_r
    saturated_water_content: float  # theta_s
    alpha_1_m: float  # a (1/m)
    specific_storage_1_m: float = 0.0  # S_s

    def __post_init__(self):
        _check_contents(self.residual_water_content, self.saturated_water_content, self.specific_storage_1_m)
        if not (math.isfinite(self.alpha_1_m) and self.alpha_1_m > 0.0):
            raise ValueError(f"Gardner alpha: need a finite a > 0 (1/m), got {self.alpha_1_m!r}")

    def effective_saturation(self, pressure_head_m) -> np.ndarray:
        """S_e = exp(a min(psi, 0))."""
        return np.exp(self.alpha_1_m * np.minimum(np.asarray(pressure_head_m, dtype=float), 0.0))

    def _saturation_slope_1_m(self, psi: np.ndarray) -> np.ndarray:
        return np.where(psi < 0.0, self.alpha_1_m * np.exp(self.alpha_1_m * np.minimum(psi, 0.0)), 0.0)

    def relative_conductivity(self, pressure_head_m) -> np.ndarray:
        """k_r = exp(a min(psi, 0))."""
        return self.effective_saturation(pressure_head_m)


SoilWaterCurve = VanGenuchten | Gardner
"""A material's soil-water characteristic curve."""
