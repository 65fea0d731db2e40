"""When a runout is over: the flow is at rest once its kinetic energy stays below a fraction of the
potential energy it has released.

    at rest at t  when  E_k(s) < f * E_released(s)  for every record s in [t - window, t],
    E_released = -(gravity potential + load potential)   (energy_budget.ENERGY_COLUMNS)

The time to rest is the start of that window.  A flow that released nothing is at rest when its
kinetic energy is zero.
"""

from __future__ import annotations

import numpy as np

from spfem_core.energy_budget import ENERGY_GRAVITY_POTENTIAL, ENERGY_KINETIC, ENERGY_LOAD_POTENTIAL


def resting(energy_j_per_m: np.ndarray, fraction: float) -> np.ndarray:
    """Per record: kinetic energy below ``fraction`` of the potential energy released (module doc)."""
    released = -(energy_j_per_m[:, ENERGY_GRAVITY_POTENTIAL] + energy_j_per_m[:, ENERGY_LOAD_POTENTIAL])
    kinetic = energy_j_per_m[:, ENERGY_KINETIC]
    return kinetic <= fraction * np.maximum(released, 0.0)


def time_to_rest_s(time_s: np.ndarray, energy_j_per_m: np.ndarray, fraction: float, window_s: float) -> float:
    """Start of the first window of ``window_s`` over which every record rests; NaN if none (yet)."""
    rest = resting(energy_j_per_m, fraction)
    if time_s.size == 0 or not rest[-1]:
        return float("nan")
    # the last run of resting records, and whether it spans the window
    moving = np.flatnonzero(~rest)
    start = 0 if moving.size == 0 else int(moving[-1]) + 1
    if time_s[-1] - time_s[start] < window_s:
        return float("nan")
    return float(time_s[start])


def rest_rule(fraction: float, window_s: float):
    """The simulation's stop rule: end the stage once the flow is at rest (module doc)."""

    def rule(time_s, max_u_m, energy):
        start = time_to_rest_s(time_s, energy, fraction, window_s)
        if start == start:
            return f"at rest from t = {start:.3g} s: kinetic energy below {fraction:g} of the potential released"
        return None

    return rule
