"""How a material model declares the properties it reads (``<model>.PROPERTIES``).

A property has a name that says its unit (``cohesion_pa``, ``friction_deg``), a default (None:
every row of the model must give it) and a range.  A property with ``choices`` (a named option,
such as the Drucker-Prager fit) is stored as the index of the choice, so that every property of
a table is a float64 column, and a table with a row per particle is as easy to build as one with
a row per material (``table.MaterialTable``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Property:
    """One property of a material model (module doc).  The range is ``ge <= value < lt`` (``lt``
    inclusive for an infinite value when ``inf_allowed``); a categorical property's value is the
    index of one of ``choices``, NaN for its default when ``default`` is NaN too."""

    name: str
    default: float | None = None
    ge: float = -math.inf
    lt: float = math.inf
    inf_allowed: bool = False
    choices: tuple[str, ...] = ()

    def encode(self, value) -> float:
        """A value as stored: a choice by its index (an empty string: NaN, the default), else a float."""
        if self.choices and isinstance(value, str):
            if value == "":
                return math.nan
            if value not in self.choices:
                raise ValueError(f"{self.name}: must be one of {self.choices}, got {value!r}")
            return float(self.choices.index(value))
        return float(value)

    def problem(self, values: np.ndarray) -> tuple[int, str] | None:
        """(first row, why) of values outside the range; None when all are allowed."""
        if self.choices:
            bad = ~(np.isnan(values) | np.isin(values, np.arange(len(self.choices))))
            return (int(np.flatnonzero(bad)[0]), f"must be one of {self.choices}") if bad.any() else None
        finite = np.isfinite(values) | (self.inf_allowed & (values == math.inf))
        bad = ~(finite & (values >= self.ge) & ((values < self.lt) | (values == math.inf)))
        if bad.any():
            upper = f" and < {self.lt:g}" if math.isfinite(self.lt) else ""
            return int(np.flatnonzero(bad)[0]), f"must be finite, >= {self.ge:g}{upper}"
        return None
