"""``[refinement]``: the spacings of a refinement study and the search at each (``workflows.refinement``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from workflows.fields import Record, StudyError, integer, number, numbers
from workflows.refinement.convergence import SAFETY_FACTOR

DEFAULT_RATIO = math.sqrt(2.0)
DEFAULT_LEVEL_TOLERANCE = 0.002
MAX_LEVELS = 6


@dataclass(frozen=True, kw_only=True)
class Refinement(Record):
    """The factor of safety at several particle spacings and its value as h -> 0."""

    spacings_m: tuple | None = numbers(
        "m", "the spacings of the levels, coarsest first (at least 3); default: geometry.spacing_m divided by "
        "ratio^k for k = 0 ... levels - 1", default=None, gt=0.0,
    )
    levels: int | None = integer("number of levels from geometry.spacing_m; default 3", default=None, ge=3,
                                 le=MAX_LEVELS)
    ratio: float | None = number(
        "1", f"spacing of one level over the next; default sqrt(2) = {DEFAULT_RATIO:.4g} (each level doubles the "
        "particles)", default=None, ge=1.1, le=2.0,
    )
    fos_tolerance: float = number(
        "1", "width of each level's FOS bracket: small against the differences between levels (replaces the "
        "stage's fos_tolerance; an adaptive study's coarse level keeps the stage's)", default=DEFAULT_LEVEL_TOLERANCE, gt=0.0, le=0.02,
    )
    safety_factor: float = number("1", "Fs of the grid convergence index with three levels (Roache)",
                                  default=SAFETY_FACTOR, ge=1.0, le=3.0)
    adaptive_spacing_m: float | None = number(
        "m", "adaptive refinement instead of levels: the study at geometry.spacing_m, then again with a zone of "
        "this spacing along the shear band of its first failed run (workflows/refinement/adaptive.py)",
        default=None, gt=0.0,
    )
    band_margin_m: float | None = number(
        "m", "*adaptive:* the zone reaches this far beyond the band on either side; default geometry.spacing_m",
        default=None, gt=0.0,
    )

    def check(self):
        if self.adaptive_spacing_m is not None:
            for name in ("spacings_m", "levels", "ratio"):
                if getattr(self, name) is not None:
                    raise StudyError(name, "give adaptive_spacing_m, or levels of spacings, not both")
        elif self.band_margin_m is not None:
            raise StudyError("band_margin_m", "applies with adaptive_spacing_m only")
        if self.spacings_m is not None:
            if self.levels is not None or self.ratio is not None:
                raise StudyError("spacings_m", "give spacings_m, or levels and ratio, not both")
            if len(self.spacings_m) < 3 or len(self.spacings_m) > MAX_LEVELS:
                raise StudyError("spacings_m", f"give 3 to {MAX_LEVELS} spacings, got {len(self.spacings_m)}")
            for i in range(1, len(self.spacings_m)):
                if not self.spacings_m[i] < self.spacings_m[i - 1] / 1.05:
                    raise StudyError(f"spacings_m[{i}]", "each spacing must be at least 5% below the one before "
                                     f"(coarsest first), got {self.spacings_m[i - 1]:g} then {self.spacings_m[i]:g}")

    def spacings(self, spacing_m: float) -> list[float]:
        """The levels' spacings, coarsest first (``spacing_m``: the study's geometry.spacing_m)."""
        if self.adaptive_spacing_m is not None:
            return [float(spacing_m), float(self.adaptive_spacing_m)]
        if self.spacings_m is not None:
            return [float(h) for h in self.spacings_m]
        ratio = DEFAULT_RATIO if self.ratio is None else self.ratio
        levels = 3 if self.levels is None else self.levels
        return [float(f"{spacing_m / ratio**k:.6g}") for k in range(levels)]
