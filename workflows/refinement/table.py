"""``[refinement]``: the levels of a refinement study and when it stops (``workflows.refinement``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from workflows.fields import Record, StudyError, integer, number, numbers, text

MIN_LEVELS = 4
"""The band's free-order fit has three parameters: a standard deviation needs a fourth level
(``workflows.refinement.convergence``)."""
DEFAULT_RATIO = math.sqrt(2.0)
DEFAULT_LEVEL_TOLERANCE = 0.002
MAX_LEVELS = 10
ADAPTIVE, UNIFORM = "adaptive", "uniform"
INDICATORS = ("plastic_work", "plastic_strain", "mechanism")
"""What marks the band an adaptive step refines (``workflows.refinement.adaptive``)."""


@dataclass(frozen=True, kw_only=True)
class Refinement(Record):
    """The factor of safety at several particle spacings, its value as h -> 0 and its uncertainty."""

    mode: str | None = text(
        "`adaptive`: the study at geometry.spacing_m, then steps that refine the particles along the shear band of "
        "the step before, each ratio times finer, until the band is narrow enough; `uniform`: the whole cloud at "
        "each of spacings_m (or levels spacings from geometry.spacing_m). Default: adaptive unless spacings_m or "
        "levels is given", default=None, choices=(ADAPTIVE, UNIFORM),
    )
    spacings_m: tuple | None = numbers(
        "m", f"*uniform:* the spacings of the levels, coarsest first (at least {MIN_LEVELS}); default: "
        "geometry.spacing_m divided by ratio^k for k = 0 ... levels - 1", default=None, gt=0.0,
    )
    levels: int | None = integer(f"*uniform:* number of levels from geometry.spacing_m; default {MIN_LEVELS}",
                                 default=None, ge=MIN_LEVELS, le=MAX_LEVELS)
    ratio: float | None = number(
        "1", f"spacing of one level over the next (adaptive: of the band's particles); default sqrt(2) = "
        f"{DEFAULT_RATIO:.4g}", default=None, ge=1.1, le=2.0,
    )
    fos_tolerance: float = number(
        "1", "width of each level's FOS bracket: small against the differences between levels (replaces the "
        "stage's fos_tolerance)", default=DEFAULT_LEVEL_TOLERANCE, gt=0.0, le=0.02,
    )
    target_uncertainty: float = number(
        "1", "*adaptive:* stop once the band's half-width U is at most this fraction of the FOS and the band is "
        f"trusted (after {MIN_LEVELS} levels at least)", default=0.005, gt=0.0, le=0.2,
    )
    max_levels: int = integer(f"*adaptive:* the most levels, the first included ({MIN_LEVELS} to {MAX_LEVELS})",
                              default=7, ge=MIN_LEVELS, le=MAX_LEVELS)
    max_particles: int = integer("*adaptive:* no level with more particles than this is made (a budget)",
                                 default=40_000, ge=100)
    indicator: str = text(
        "*adaptive:* what marks the band to refine, in the first failed run of the level before: `plastic_work` "
        "(sqrt(J2) times the equivalent plastic strain), `plastic_strain`, or `mechanism` (the plastic strain that "
        "run gained over the highest stable run below it)", default="plastic_work", choices=INDICATORS,
    )
    band_reach: float = number(
        "1", "*adaptive:* a refined zone reaches this many spacings of the level before beyond the band it refines",
        default=3.0, ge=1.0, le=20.0,
    )
    jitter: float = number(
        "1", "random offset of the levels' interior particles, a fraction of their spacing (as geometry.jitter, "
        "which it replaces); the scatter of the FOS is measured by repeating the second level with another seed "
        "(0: no repeat, the scatter is the fit's alone)", default=0.1, ge=0.0, lt=0.3,
    )

    def check(self):
        uniform_fields = [name for name in ("spacings_m", "levels") if getattr(self, name) is not None]
        if self.mode == ADAPTIVE and uniform_fields:
            raise StudyError(uniform_fields[0], "applies to mode = \"uniform\" (an adaptive study makes its own levels)")
        if self.spacings_m is not None:
            if self.levels is not None or self.ratio is not None:
                raise StudyError("spacings_m", "give spacings_m, or levels and ratio, not both")
            if len(self.spacings_m) < MIN_LEVELS or len(self.spacings_m) > MAX_LEVELS:
                raise StudyError("spacings_m", f"give {MIN_LEVELS} to {MAX_LEVELS} spacings, got {len(self.spacings_m)}: "
                                 f"the uncertainty of the FOS at h -> 0 needs {MIN_LEVELS} levels at least")
            for i in range(1, len(self.spacings_m)):
                if not self.spacings_m[i] < self.spacings_m[i - 1] / 1.05:
                    raise StudyError(f"spacings_m[{i}]", "each spacing must be at least 5% below the one before "
                                     f"(coarsest first), got {self.spacings_m[i - 1]:g} then {self.spacings_m[i]:g}")

    def check_in_study(self, study) -> None:
        """A refinement study computes a factor of safety: the study needs a strength-reduction stage."""
        if study.strength_reduction is None:
            raise StudyError("refinement", "a refinement study computes a factor of safety: it needs a "
                             "strength_reduction stage")

    @property
    def adaptive(self) -> bool:
        return self.kind == ADAPTIVE

    @property
    def kind(self) -> str:
        """ADAPTIVE or UNIFORM (the default: module doc of the field ``mode``)."""
        if self.mode is not None:
            return self.mode
        return UNIFORM if self.spacings_m is not None or self.levels is not None else ADAPTIVE

    @property
    def spacing_ratio(self) -> float:
        return DEFAULT_RATIO if self.ratio is None else self.ratio

    def spacings(self, spacing_m: float) -> list[float]:
        """A uniform study's spacings, coarsest first; an adaptive study's first ``max_levels`` band
        spacings (``spacing_m``: the study's geometry.spacing_m, the first level's)."""
        if self.spacings_m is not None:
            return [float(h) for h in self.spacings_m]
        count = self.max_levels if self.adaptive else (MIN_LEVELS if self.levels is None else self.levels)
        return [float(f"{spacing_m / self.spacing_ratio**k:.6g}") for k in range(count)]
