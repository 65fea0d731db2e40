"""``kind = "relaxation"``: dynamic relaxation, locally damped steps until the slope is at rest
(the gravity stage of a study).

At rest: |f_unbalanced| / |m g| < ``tolerance`` over the free directions (``Simulation.relax``),
or ``max_duration_s`` (the result says it did not converge).  When the next stage starts from the
original positions, the water pressures act as at the initial positions (the settlement of a
relaxation from zero stress is discarded, ``spfem_core.external_forces``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import boolean, number
from workflows.stages.base import StageBase


@dataclass(frozen=True, kw_only=True)
class RelaxationStage(StageBase):
    """Dynamic relaxation: damped steps until the unbalanced-force ratio falls below a tolerance."""

    kind: ClassVar[str] = "relaxation"
    duration_field: ClassVar[str] = "max_duration_s"
    max_duration_s: float = number("s", "stop here even if not converged (the result records it)", gt=0.0)
    tolerance: float = number(
        "1", "converged when the unbalanced-force ratio is below this", default=1e-5, gt=0.0, lt=1.0
    )
    damping: float = number("1", "local (Cundall) damping factor", default=0.7, gt=0.0, lt=1.0)
    elastic_solve: bool = boolean(
        "when every material of the stage is elastic, start from the static small-strain solution of its loads "
        "(one sparse direct solve); the damped steps then only correct the large-deformation geometry. false: "
        "relax from the state as it is", default=True,
    )

    def run(self, sim, monitor_nodes, *, progress=None, snapshot=None, next_starts_over=False):
        """Relax until at rest (module doc)."""
        return sim.relax(damping=self.damping, tolerance=self.tolerance, max_duration_s=self.max_duration_s,
                         record_interval_s=self.record_interval_s, monitor_nodes=monitor_nodes, progress=progress,
                         snapshot=snapshot, water_at_initial_positions=next_starts_over,
                         elastic_solve_first=self.elastic_solve)
