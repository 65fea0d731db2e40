"""``[sweep]``: a parameter study, the study run once per combination of its axes' values."""

from __future__ import annotations

import math
from dataclasses import dataclass

from workflows.fields import Record, StudyError, any_values, integer, number, tables, text

MAX_SWEEP_CASES = 10000
"""A sweep makes at most this many cases."""


@dataclass(frozen=True, kw_only=True)
class SweepAxis(Record):
    """One swept parameter: its path in the study file and its values."""

    path: str = text(
        "the field to sweep, by its path, entries of arrays of tables by name: `materials.soil.cohesion_pa`, "
        "`geometry.slope.angle_deg`, `stages.srf.duration_s`"
    )
    values: tuple | None = any_values(
        "the values, each checked like the field itself; or give start, stop and count", default=None,
    )
    start: float | None = number("1", "first value of an evenly spaced range (in the field's unit)", default=None)
    stop: float | None = number("1", "last value of the range", default=None)
    count: int | None = integer("number of values of the range, start and stop included", default=None, ge=2,
                                le=1000)

    def check(self):
        ranged = (self.start, self.stop, self.count)
        if self.values is not None and any(v is not None for v in ranged):
            raise StudyError("values", "give values, or start, stop and count, not both")
        if self.values is None and any(v is None for v in ranged):
            missing = next(name for name, v in zip(("start", "stop", "count"), ranged) if v is None)
            raise StudyError(missing, "required field missing (give values, or start, stop and count)")
        if self.values is not None:
            for j, value in enumerate(self.values):
                if value in self.values[:j]:
                    raise StudyError(f"values[{j}]", f"{value!r} appears twice (each value is one case)")
        elif self.start == self.stop:
            raise StudyError("stop", "must differ from start")

    @property
    def points(self) -> tuple:
        """The values of the axis: ``values``, or ``count`` evenly spaced from ``start`` to ``stop``."""
        if self.values is not None:
            return self.values
        step = (self.stop - self.start) / (self.count - 1)
        return tuple(self.start + i * step for i in range(self.count - 1)) + (self.stop,)


@dataclass(frozen=True, kw_only=True)
class Sweep(Record):
    """A parameter study: the study runs once per combination of its axes' values (a case each)."""

    combination: str = text(
        "`grid`: every combination of the axes' values; `zip`: the i-th values of all axes together (axes of "
        "equal length)", default="grid", choices=("grid", "zip"),
    )
    axes: tuple = tables(SweepAxis, "the swept parameters", min_items=1, unique="path")

    def check(self):
        sizes = [len(axis.points) for axis in self.axes]
        if self.combination == "zip" and len(set(sizes)) > 1:
            raise StudyError("axes", f"zip needs axes of equal length, got {sizes} values")
        cases = sizes[0] if self.combination == "zip" else math.prod(sizes)
        if cases > MAX_SWEEP_CASES:
            raise StudyError("axes", f"make {cases} cases, more than {MAX_SWEEP_CASES}")
