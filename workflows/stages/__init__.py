"""The kinds of stage of a study file, one module each, and their registry.

Each module is one class built on ``base.StageBase`` (declaration, checks, what it sets before it
starts, how it runs, what it adds to its results, flags); ``running`` prepares and runs any of
them on a simulation and makes its result.  :data:`STAGE_KINDS` is the one list of them; adding
a kind: docs/architecture.md.
"""

from __future__ import annotations

from workflows.stages.base import StageBase
from workflows.stages.dynamic import DynamicStage
from workflows.stages.relaxation import RelaxationStage
from workflows.stages.runout import RunoutStage
from workflows.stages.strength_reduction import StrengthReductionStage

STAGE_KINDS: dict[str, type[StageBase]] = {
    stage.kind: stage for stage in (DynamicStage, RelaxationStage, RunoutStage, StrengthReductionStage)
}
"""Every kind of stage of a study file, by its ``kind`` name."""

__all__ = ["STAGE_KINDS", "DynamicStage", "RelaxationStage", "RunoutStage", "StageBase", "StrengthReductionStage"]
