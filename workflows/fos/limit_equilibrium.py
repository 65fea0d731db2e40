"""Spencer's limit-equilibrium factor of safety on a given slip line, by the method of slices.

The mass above the slip line is cut into vertical slices moving towards +x (a slope facing the
other way is mirrored first).  Slice i has the base midpoint (x_i, y_i), the base inclination
alpha_i (positive where the base descends towards +x), the base length l_i = b_i / cos alpha_i,
the vertical load W_i (weight and surface loads), the horizontal body force K_i (towards +x,
acting a_i above the base midpoint), the pore-water force U_i = u_i l_i and the strength c_i,
phi_i.  Spencer (1967) takes the interslice forces parallel, at one inclination theta: the net
interslice force on slice i is Q_i (cos theta, sin theta).  Equilibrium of the slice normal to
and along its base, with the mobilised shear S_i = (c_i l_i + N'_i tan phi_i) / F, gives

    Q_i = [c_i l_i + tan phi_i (W_i cos a - K_i sin a - U_i) - F (W_i sin a + K_i cos a)]
          / [F cos(a + theta) + tan phi_i sin(a + theta)]           (a = alpha_i),

and the mass is in equilibrium when the interslice forces balance in force and in moment:

    sum_i Q_i = 0,        sum_i [Q_i (x_i sin theta - y_i cos theta) + K_i a_i] = 0

(each Q_i acts through its base midpoint, where W_i, N_i and S_i meet; K_i's arm adds its
moment).  The two equations give F and theta; Morgenstern-Price with a constant f(x) is the
same method.  Verified against Fredlund & Krahn (1977) (tests/test_limit_equilibrium.py).

A slice's strength is its material's (:func:`material_strengths`): the strength each material
model of the core gives a support the soil slides along (its ``slip_strength``), unreduced.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from spfem_core.materials.table import MaterialTable


@dataclass(frozen=True)
class Slices:
    """The slices of a sliding mass moving towards +x, arrays of one value per slice (SI units, per
    metre of thickness)."""

    x_m: np.ndarray  # base midpoint
    y_m: np.ndarray
    width_m: np.ndarray  # b
    alpha_rad: np.ndarray  # base inclination, positive where the base descends towards +x
    vertical_load_n: np.ndarray  # W: weight and surface loads, downward positive
    horizontal_load_n: np.ndarray  # K: horizontal body force towards +x (pseudo-static earthquake)
    horizontal_arm_m: np.ndarray  # a: height of K's line of action above the base midpoint
    pore_pressure_pa: np.ndarray  # u at the base midpoint (compression positive)
    cohesion_pa: np.ndarray
    tan_friction: np.ndarray


def material_strengths(materials) -> tuple[np.ndarray, np.ndarray]:
    """(c in Pa, tan phi) of each of a study's ``materials`` (``workflows.materials``), unreduced: the
    shear strength tau = c + sigma_n tan(phi) its core model gives a support the soil slides along
    (``MaterialTable.slip_strength``, each model's own ``slip_strength``: c' and phi' of the
    frictional models, their peak values where they soften; c_u and phi = 0 of Tresca); c = inf for
    a material without strength (elastic)."""
    return MaterialTable.from_rows([material.core_row() for material in materials]).slip_strength()


@dataclass(frozen=True)
class SpencerResult:
    fos: float  # NaN: no solution
    theta_rad: float  # inclination of the interslice forces
    reason: str  # how it was solved, or why there is no solution


def _interslice_forces(slices: Slices, fos: float, theta: float) -> np.ndarray:
    """Q_i (module doc)."""
    a, tan_phi = slices.alpha_rad, slices.tan_friction
    w, k = slices.vertical_load_n, slices.horizontal_load_n
    length = slices.width_m / np.cos(a)
    resisting = slices.cohesion_pa * length + tan_phi * (w * np.cos(a) - k * np.sin(a) - slices.pore_pressure_pa
                                                          * length)
    driving = w * np.sin(a) + k * np.cos(a)
    return (resisting - fos * driving) / (fos * np.cos(a + theta) + tan_phi * np.sin(a + theta))


def _residuals(slices: Slices, fos: float, theta: float) -> np.ndarray:
    """The force and moment sums (module doc), made dimensionless by the total load and its extent."""
    q = _interslice_forces(slices, fos, theta)
    x = slices.x_m - slices.x_m.mean()
    y = slices.y_m - slices.y_m.mean()
    load = np.abs(slices.vertical_load_n).sum() + np.abs(slices.horizontal_load_n).sum()
    extent = np.ptp(slices.x_m) + np.ptp(slices.y_m) + slices.width_m.sum()
    moment = q * (x * np.sin(theta) - y * np.cos(theta)) + slices.horizontal_load_n * slices.horizontal_arm_m
    return np.array([q.sum() / load, moment.sum() / (load * extent)])


def _ordinary_fos(slices: Slices) -> float:
    """Fellenius' factor of safety, Spencer's starting point."""
    a = slices.alpha_rad
    length = slices.width_m / np.cos(a)
    normal = np.maximum(slices.vertical_load_n * np.cos(a) - slices.pore_pressure_pa * length, 0.0)
    driving = (slices.vertical_load_n * np.sin(a) + slices.horizontal_load_n * np.cos(a)).sum()
    resisting = (slices.cohesion_pa * length + slices.tan_friction * normal).sum()
    return float(resisting / driving) if driving > 0.0 else float("nan")


def spencer(slices: Slices, tolerance: float = 1e-10) -> SpencerResult:
    """Spencer's F and theta of ``slices`` (module doc), by Newton-type root finding from
    Fellenius' F and theta = 0, then from a few other starts; a solution must have F > 0, theta in
    (-pi/2, pi/2) and every slice's denominator positive (no slice with a negative normal force
    factor, the m_alpha problem)."""
    start = _ordinary_fos(slices)
    if not np.isfinite(start) or start <= 0.0:
        return SpencerResult(float("nan"), float("nan"), "the slices drive no motion towards +x")
    for fos0, theta0 in ((start, 0.0), (start, 0.3), (start, -0.3), (1.0, 0.0), (2.0 * start, 0.2)):
        solution = optimize.root(lambda v: _residuals(slices, v[0], v[1]), [fos0, theta0], method="hybr",
                                 options={"xtol": tolerance})
        fos, theta = (float(v) for v in solution.x)
        if not (solution.success and fos > 0.0 and abs(theta) < 0.5 * np.pi):
            continue
        denominator = fos * np.cos(slices.alpha_rad + theta) + slices.tan_friction * np.sin(slices.alpha_rad + theta)
        if np.all(denominator > 0.0) and np.all(np.abs(_residuals(slices, fos, theta)) < 1e-6):
            return SpencerResult(fos, theta, "Spencer (1967): force and moment equilibrium, parallel interslice forces")
    return SpencerResult(float("nan"), float("nan"), "Spencer's equations have no admissible solution on this line")
