"""Telling a run that blew up from one that did not.

Three signs, checked between compiled calls from what the loop reports and records:

- a velocity that is not finite (NaN or inf);
- a particle faster than the P-wave speed of the fastest material (runaway kinetic energy);
- energy created: kinetic + strain + gravity and load potentials + everything dissipated has
  grown since the stage start by more than ``ENERGY_CREATED_LIMIT`` of the largest energy scale
  (kinetic + strain + |gravity potential| + |load potential|) seen so far.  A stable run only loses energy (about 1-2%
  leapfrog wobble).  Only checked when no particle has a prescribed non-zero velocity (that
  work is not in the budget).

A mesh rebuild that would stall the run (:class:`MeshCollapse`) ends it as a divergence too.
"""

from __future__ import annotations

from spfem_core.energy_budget import ENERGY_GRAVITY_POTENTIAL, ENERGY_KINETIC, ENERGY_LOAD_POTENTIAL, ENERGY_STRAIN

ENERGY_CREATED_LIMIT = 0.25
"""Divergence when the energy budget has grown by more than this fraction of its scale (module doc)."""


class DivergenceError(RuntimeError):
    """The solution blew up; ``step`` and ``time_s`` say where, ``partial`` holds the records so far."""

    def __init__(self, reason: str, step: int, time_s: float, partial=None):
        super().__init__(f"run diverged at step {step} (t = {time_s:.6g} s): {reason}")
        self.reason = reason
        self.step = step
        self.time_s = time_s
        self.partial = partial


class MeshCollapse(Exception):
    """A mesh rebuild that would stall the run: its critical time step fell below
    ``timestep.DT_COLLAPSE_FACTOR`` of the stage's first (``Simulation.rebuild_mesh``); the stage
    loop turns it into a DivergenceError with the records so far."""


def speed_reason(not_finite: bool, max_speed_m_s: float, speed_limit_m_s: float) -> str:
    """The one-line reason of a velocity divergence."""
    if not_finite:
        return "velocity is not finite"
    return (f"a particle moves at {max_speed_m_s:.4g} m/s, faster than the P-wave speed {speed_limit_m_s:.4g} m/s "
            "(runaway kinetic energy)")


class EnergyWatch:
    """The energy-created check over the rows a stage has recorded so far (module doc)."""

    def __init__(self, records):
        """``records``: the stage's ``records.RecordBuffers`` with its first row written."""
        self.start_j_per_m = float(records.energy_j_per_m[0].sum())
        self.scale_j_per_m = 0.0
        self.checked = 0

    def reason(self, records) -> str | None:
        """Why the rows recorded since the last call show a divergence, or None."""
        energy = records.energy_j_per_m
        n_filled = records.n_filled
        for row in range(self.checked, n_filled):
            scale = (energy[row, ENERGY_KINETIC] + energy[row, ENERGY_STRAIN]
                     + abs(energy[row, ENERGY_GRAVITY_POTENTIAL]) + abs(energy[row, ENERGY_LOAD_POTENTIAL]))
            self.scale_j_per_m = max(self.scale_j_per_m, scale)
            created = float(energy[row].sum()) - self.start_j_per_m
            if not created <= ENERGY_CREATED_LIMIT * self.scale_j_per_m:  # NaN too
                self.checked = row + 1
                return (
                    f"the run created energy: {created:.4g} J/m at t = {records.time_s[row]:.6g} s, "
                    f"more than {ENERGY_CREATED_LIMIT:g} of the energy scale {self.scale_j_per_m:.4g} J/m"
                )
        self.checked = n_filled
        return None
