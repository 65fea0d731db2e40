"""``kind = "dynamic"``: explicit dynamics for a fixed duration, with optional local damping."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import number
from workflows.stages.base import StageBase


@dataclass(frozen=True, kw_only=True)
class DynamicStage(StageBase):
    """Explicit dynamics for a fixed duration."""

    kind: ClassVar[str] = "dynamic"
    duration_field: ClassVar[str] = "duration_s"
    animated: ClassVar[bool] = True
    duration_s: float = number("s", "simulated time of the stage", gt=0.0)
    damping: float = number(
        "1", "local (Cundall) damping factor; 0 is undamped dynamics", default=0.0, ge=0.0, lt=1.0
    )

    def run(self, sim, monitor_nodes, *, progress=None, snapshot=None, next_starts_over=False):
        """``duration_s`` of explicit steps with local damping ``damping`` (``Simulation.run``)."""
        return sim.run(self.duration_s, damping=self.damping, record_interval_s=self.record_interval_s,
                       monitor_nodes=monitor_nodes, progress=progress, snapshot=snapshot)
