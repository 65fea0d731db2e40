"""``[geometry]``: the domain and its particle cloud, given as a polygon or made from a slope's
dimensions (``[geometry.slope]``) or a section drawn as lines (``[geometry.section]``), with the
zones of finer spacing; and the checks of each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import narrow_peaks, points_in_polygon
from workflows.fields import (
    Record,
    StudyError,
    integer,
    name_field,
    number,
    numbers,
    optional_table,
    polygon,
    polyline,
    tables,
)


@dataclass(frozen=True, kw_only=True)
class SlopeForm(Record):
    """A slope from its dimensions: flat ground behind the crest, the face, flat ground beyond the
    toe, on a foundation; it makes the polygon, and the supports and monitors a study leaves out."""

    height_m: float = number("m", "height H of the slope, toe to crest", gt=0.0)
    angle_deg: float | None = number(
        "degree", "inclination of the face from horizontal; give angle_deg or gradient", default=None, gt=0.0, le=90.0,
    )
    gradient: float | None = number(
        "1", "horizontal run of the face per unit of height (2 for 1V:2H); give angle_deg or gradient",
        default=None, ge=0.0,
    )
    crest_length_m: float | None = number(
        "m", "length of the flat ground behind the crest; default 2 H", default=None, gt=0.0,
    )
    toe_length_m: float | None = number(
        "m", "length of the flat ground beyond the toe (not used without a foundation); default 2 H", default=None,
        gt=0.0,
    )
    foundation_depth_m: float | None = number(
        "m", "depth of the ground below the toe down to the fixed base; 0: a rigid base at the toe; default H / 2",
        default=None, ge=0.0,
    )
    layer_depths_m: tuple = numbers(
        "m", "depths below the crest of horizontal boundaries between layers: the materials without region_m "
        "fill the layers from the top, in file order", default=(), gt=0.0,
    )

    def check(self):
        if (self.angle_deg is None) == (self.gradient is None):
            raise StudyError("angle_deg", "give angle_deg or gradient (one of them)")
        depths = list(self.layer_depths_m)
        if depths != sorted(set(depths)):
            raise StudyError("layer_depths_m", f"must increase, got {list(depths)}")
        if depths and depths[-1] >= self.height_m + self.foundation_depth:
            raise StudyError("layer_depths_m", f"must lie above the base, {self.height_m + self.foundation_depth:g} m "
                             f"below the crest, got {depths[-1]:g}")

    @property
    def run_m(self) -> float:
        """Horizontal run of the face."""
        if self.gradient is not None:
            return self.gradient * self.height_m
        return 0.0 if self.angle_deg == 90.0 else self.height_m / math.tan(math.radians(self.angle_deg))

    @property
    def crest_length(self) -> float:
        return 2.0 * self.height_m if self.crest_length_m is None else self.crest_length_m

    @property
    def toe_length(self) -> float:
        return 2.0 * self.height_m if self.toe_length_m is None else self.toe_length_m

    @property
    def foundation_depth(self) -> float:
        return 0.5 * self.height_m if self.foundation_depth_m is None else self.foundation_depth_m


@dataclass(frozen=True, kw_only=True)
class SectionLayer(Record):
    """Where one material lies in a section drawn as lines: above a line, below one, or between two
    (over the x-range the lines share); the lines run left to right and the code closes them into
    the material's region."""

    material: str = name_field("name of the [[materials]] entry this layer places (it gives no region_m)")
    above_m: tuple | None = polyline("m", "the material lies above this line, [[x, y], ...], x increasing",
                                     default=None)
    below_m: tuple | None = polyline("m", "the material lies below this line, [[x, y], ...], x increasing",
                                     default=None)

    def check(self):
        if self.above_m is None and self.below_m is None:
            raise StudyError("above_m", "give above_m, below_m or both (the lines that bound the layer)")
        if self.above_m is not None and self.below_m is not None:
            low = max(self.above_m[0][0], self.below_m[0][0])
            high = min(self.above_m[-1][0], self.below_m[-1][0])
            if not low < high:
                raise StudyError("below_m", f"shares no x-range with above_m (x = {self.above_m[0][0]:g} to "
                                 f"{self.above_m[-1][0]:g} against {self.below_m[0][0]:g} to {self.below_m[-1][0]:g})")
            xs = sorted({x for x, _ in (*self.above_m, *self.below_m) if low <= x <= high})
            lower = np.interp(xs, *np.array(self.above_m).T)
            upper = np.interp(xs, *np.array(self.below_m).T)
            crossing = np.flatnonzero(upper < lower)
            if crossing.size:
                x = xs[crossing[0]]
                raise StudyError("below_m", f"passes under above_m at x = {x:g} m (the layer lies below below_m "
                                 "and above above_m: the lines may meet, not cross)")


@dataclass(frozen=True, kw_only=True)
class SectionForm(Record):
    """A section drawn as engineers draw it: the ground surface as a line, a base below it, and the
    layers by their boundary lines; it makes the polygon, the materials' regions, and the supports a
    study leaves out (a fixed base, rollers on both sides)."""

    ground_m: tuple = polyline("m", "the ground surface from left to right, [[x, y], ...], x increasing: its ends "
                               "are the section's sides")
    base_y_m: float = number("m", "level of the fixed base of the section, below every point of the ground")
    layers: tuple = tables(SectionLayer, "materials placed by lines; the others fill the rest of the section "
                           "(a material with no layer and no region_m fills all of it, under the later ones)",
                           unique="material")

    def check(self):
        lowest = min(y for _, y in self.ground_m)
        if self.base_y_m >= lowest:
            raise StudyError("base_y_m", f"must lie below the ground, whose lowest point is at y = {lowest:g} m, "
                             f"got {self.base_y_m:g}")


MAX_GRADING = 1.5
"""Largest ``geometry.grading``: steeper transitions leave holes in the first mesh of jittered clouds."""


@dataclass(frozen=True, kw_only=True)
class RefinedZone(Record):
    """A zone of the domain with a finer particle spacing (``spfem_core.cloud.graded_particles_in_polygon``)."""

    name: str = name_field("name of the zone")
    region_m: tuple = polygon("m", "outline of the zone, [[x, y], ...]; the part inside the domain is refined")
    spacing_m: float = number("m", "particle spacing inside the zone, at most geometry.spacing_m", gt=0.0)


@dataclass(frozen=True, kw_only=True)
class Geometry(Record):
    """The domain and its particle cloud: a polygon (given, or made by [geometry.slope]) filled with
    particles at spacing h."""

    polygon_m: tuple | None = polygon(
        "m", "outline of the domain, [[x, y], ...], either orientation, not closed; give polygon_m, "
        "[geometry.slope] or [geometry.section]", default=None,
    )
    spacing_m: float = number("m", "particle spacing h of the lattice clipped to the polygon", gt=0.0)
    jitter: float = number(  # lt: spfem_core.cloud.MAX_JITTER (not imported: it would import numba)
        "1", "random offset of interior particles, as a fraction of h", default=0.0, ge=0.0, lt=0.3
    )
    seed: int = integer("seed of the random jitter", default=0, ge=0)
    slope: SlopeForm | None = optional_table(SlopeForm)
    section: SectionForm | None = optional_table(SectionForm)
    refined: tuple = tables(RefinedZone, "zones with a finer spacing; around them the spacing grows by the "
                            "factor grading per spacing of distance, up to spacing_m", unique="name")
    grading: float = number(
        "1", "largest ratio between the spacings of neighbouring particles around refined zones (the spacing "
        "grows by grading - 1 per metre of distance from a zone)", default=1.25, ge=1.05, le=MAX_GRADING,
    )

    @property
    def zones(self) -> list[tuple]:
        """(polygon, spacing) of each refined zone, for ``spfem_core.cloud``."""
        return [(zone.region_m, zone.spacing_m) for zone in self.refined]

    @property
    def finest_spacing_m(self) -> float:
        """The smallest spacing of the cloud: of a refined zone, else spacing_m."""
        return min([self.spacing_m, *(zone.spacing_m for zone in self.refined)])

    def check(self):
        if self.polygon_m is None:
            raise StudyError("polygon_m", "required field missing (or give a [geometry.slope] or [geometry.section] "
                             "table)")
        xs, ys = [x for x, _ in self.polygon_m], [y for _, y in self.polygon_m]
        extent = min(max(xs) - min(xs), max(ys) - min(ys))
        if self.spacing_m > 0.5 * extent:
            raise StudyError("spacing_m", f"{self.spacing_m:g} m is more than half the domain's smaller extent "
                             f"({extent:g} m): too few particles across it")
        reach_m = max(abs(v) for vertex in self.polygon_m for v in vertex)
        corner = (math.floor(min(xs)), math.floor(min(ys)))
        local_reach_m = max(max(xs) - corner[0], max(ys) - corner[1])
        limit_m = POSITION_RESOLUTION * self.finest_spacing_m
        if math.ulp(reach_m) > limit_m and not math.ulp(local_reach_m) > limit_m:  # the offset, not the spacing
            raise StudyError("polygon_m", f"double precision resolves only {math.ulp(reach_m):.2g} m at coordinates "
                             f"of {reach_m:.3g} m, more than {POSITION_RESOLUTION:g} of the spacing "
                             f"{self.finest_spacing_m:g} m: the particles' small motions would be lost to rounding; "
                             f"draw the section in local coordinates (subtract {corner[0]} from every x and "
                             f"{corner[1]} from every y)")
        for i, zone in enumerate(self.refined):
            if zone.spacing_m > self.spacing_m:
                raise StudyError(f"refined[{i}].spacing_m", f"{zone.spacing_m:g} m is coarser than geometry.spacing_m "
                                 f"= {self.spacing_m:g} m: a zone refines")
        self._check_peaks()

    def _check_peaks(self):
        """StudyError on the ground line (``section.ground_m``, else ``polygon_m``) where a peak of the
        upper boundary is narrower than the spacing there, one spacing below its top
        (``spfem_core.geometry.narrow_peaks``): no particle fills it, yet it would count as ground
        (the slope's height, the response time).  The spacing of a peak in a refined zone is the
        finest such zone's, else ``spacing_m``."""
        field = "section.ground_m" if self.section is not None else "polygon_m"
        for spacing_m in sorted({self.spacing_m, *(zone.spacing_m for zone in self.refined)}):
            for x, y, width in narrow_peaks(self.polygon_m, spacing_m):
                zones = [zone.spacing_m for zone in self.refined if points_in_polygon([(x, y)], zone.region_m)[0]]
                if min([self.spacing_m, *zones]) == spacing_m:
                    raise StudyError(field, f"the peak at ({x:.6g}, {y:.6g}) m is narrower than the particle spacing "
                                     f"{spacing_m:g} m ({width:.2g} m wide {spacing_m:g} m below its top): no particle "
                                     f"can fill it, yet it would count in the slope's height; remove it, or make it at "
                                     f"least {spacing_m:g} m wide {spacing_m:g} m below its top")


POSITION_RESOLUTION = 1e-8
"""The spacing of floats at the farthest coordinate (``math.ulp``) is at most this fraction of the
finest particle spacing h, so that rounding the positions hides no motion that counts (the
displacement floor of a run is 5e-6 of the slope height).  Survey coordinates of 1e7 m pass
from h = 0.19 m.  (A spacing too fine for the section's own size is the particle count's to
refuse: ``workflows.memory_guard``.)"""
