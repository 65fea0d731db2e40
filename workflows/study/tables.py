"""The tables of a study file, one frozen dataclass each, and the whole :class:`Study`.

The tables of the kinds of things live in their rooms and come here through their registries:
material models (``workflows.materials``, ``[[materials]]`` by ``model``), stage kinds
(``workflows.stages``, ``[[stages]]`` by ``kind``), loads (``workflows.loads``, ``[loads]``) and
water (``workflows.water.table``, ``[water]``).  A new kind is a module there, not an edit here.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from spfem_core.geometry import narrow_peaks, points_in_polygon, relief_m
from spfem_core.settings import DEFAULT_ALPHA, DEFAULT_CFL, DEFAULT_MIN_ANGLE_DEG, DEFAULT_STABILISATION_BETA
from workflows.box import Box
from workflows.collapse.experiment import GRANULAR_COLUMN_M
from workflows.fields import (
    Record,
    StudyError,
    any_values,
    boolean,
    integer,
    name_field,
    number,
    numbers,
    optional_table,
    point,
    polygon,
    polyline,
    table,
    tables,
    text,
)
from workflows.loads import Loads
from workflows.materials import MATERIAL_MODELS
from workflows.probabilistic.table import Probabilistic
from workflows.random_field.table import RandomField
from workflows.refinement.table import Refinement
from workflows.seepage.table import Seepage
from workflows.stages import STAGE_KINDS
from workflows.stages.strength_reduction import StrengthReductionStage
from workflows.water.table import Water


@dataclass(frozen=True, kw_only=True)
class StudyInfo(Record):
    """What the study is: its name (the default output folder) and a description."""

    name: str = name_field("name of the study; the default output folder is `./<name>`")
    description: str = text("free text: what the study reproduces and why", default="")


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


@dataclass(frozen=True, kw_only=True)
class Boundary(Box):
    """Prescribed velocity on the particles initially inside a box (closed, tolerance h/1000).

    A missing bound leaves the box open on that side; a missing velocity leaves that
    direction free (vx = 0 alone is a roller).  A support that holds both velocities at 0 along
    one straight horizontal or vertical line is rough by default (``slip = "soil"``): held across
    the line, the soil sliding along it at its own strength (docs/method.md, section 3), as a rigid
    rough base lets it; ``slip = "welded"`` holds both directions instead.
    """

    name: str = name_field("name of the boundary condition")
    vx_m_s: float | None = number("m s-1", "prescribed x velocity; default: free", default=None)
    vy_m_s: float | None = number("m s-1", "prescribed y velocity; default: free", default=None)
    slip: str | None = text(
        "how the soil moves along the support: `soil`: held at 0 across it, sliding along it once its shear force "
        "passes the soil's strength, c + sigma_n tan(phi) (reduced by the SRF) over each particle's share of the "
        "support: a firm rough base; `welded`: both directions held, no sliding; `none`: the directions not "
        "prescribed are free (a smooth roller). Default: `soil` for a support that holds both velocities at 0 "
        "along one straight horizontal or vertical line of particles (a rough rigid base), `none` otherwise",
        default=None, choices=("none", "soil", "welded"),
    )

    def check(self):
        if self.vx_m_s is None and self.vy_m_s is None:
            raise StudyError("vx_m_s", "give vx_m_s, vy_m_s or both (a boundary must prescribe something)")
        if self.slip == "soil" and (self.vx_m_s or self.vy_m_s):
            raise StudyError("slip", "a slip support holds its prescribed direction at 0 m s-1")
        if self.slip == "welded" and None in (self.vx_m_s, self.vy_m_s):
            raise StudyError("slip", "a welded support prescribes both directions: give vx_m_s and vy_m_s")
        super().check()

    @property
    def holds_both_at_rest(self) -> bool:
        """Both velocities prescribed at 0: a rigid support, rough unless ``slip`` says otherwise."""
        return self.vx_m_s == 0.0 and self.vy_m_s == 0.0


@dataclass(frozen=True, kw_only=True)
class Wall(Record):
    """A rigid wall: a straight segment with Coulomb friction; material lies on its left
    when going from start to end (a floor runs in +x)."""

    name: str = name_field("name of the wall")
    start_m: tuple = point("m", "first end of the segment [x, y]")
    end_m: tuple = point("m", "second end of the segment [x, y]")
    friction: float = number("1", "Coulomb friction coefficient mu (0: frictionless)", default=0.0, ge=0.0)

    def check(self):
        if self.start_m == self.end_m:
            raise StudyError("end_m", "must differ from start_m (a wall needs a length)")


@dataclass(frozen=True, kw_only=True)
class Solver(Record):
    """Numerical settings: time step, stabilisation and the alpha-shape of the mesh."""

    cfl: float | None = number(
        "1", f"time step as a fraction of the critical step; default {DEFAULT_CFL} when dt_s is not given",
        default=None, gt=0.0, le=1.0,
    )
    dt_s: float | None = number(
        "s", "fixed time step instead of cfl; refused if above the stable step, the critical step / (1 + beta)", default=None, gt=0.0
    )
    stabilisation_beta: float = number(
        "1", "rank-deficiency stabilisation factor beta; 0 switches it off (a relaxation of elastic materials, a "
        "gravity stage, runs without it: the bonds vanish at rest)", default=DEFAULT_STABILISATION_BETA, ge=0.0
    )
    alpha: float = number(
        "1", "alpha-shape factor: triangles with circumradius > alpha h are dropped", default=DEFAULT_ALPHA, ge=1.0,
        le=3.0,
    )
    remesh_min_angle_deg: float = number(
        "degree", "rebuild the mesh when its smallest angle falls below this; after each rebuild the "
        "threshold is the fresh mesh's smallest angle less 5 degrees (or half of it, if that is larger), "
        "never above this", default=DEFAULT_MIN_ANGLE_DEG, gt=0.0, lt=60.0,
    )
    density_scaling: bool = boolean(
        "with [[geometry.refined]] zones: relaxations (gravity, quasi-static SRF runs) scale the fine particles' "
        "inertia to step at the coarse particles' critical step; the fine zone then responds slower in "
        "pseudo-time (give longer durations); measured no faster where the mechanism is refined "
        "(docs/method.md, section 5)", default=False,
    )
    uniform_relaxation_step: bool = boolean(
        "relaxations (gravity, quasi-static SRF runs) give the few particles whose cells hold the stable step "
        "down (at the free surface) more inertia, so that no cell steps below the median cell: about half the "
        "steps to the same end state (docs/method.md, section 5); false: every particle's inertia is its mass",
        default=True,
    )

    def check(self):
        if self.cfl is not None and self.dt_s is not None:
            raise StudyError("dt_s", "give cfl or dt_s, not both")


@dataclass(frozen=True, kw_only=True)
class Monitor(Record):
    """A point whose nearest particle is recorded (displacement, velocity, stress)."""

    name: str = name_field("name of the monitor; the value of the monitor coordinate of the results")
    x_m: float = number("m", "x of the point, inside or on the polygon")
    y_m: float = number("m", "y of the point, inside or on the polygon")


@dataclass(frozen=True, kw_only=True)
class Metrics(Record):
    """Scalars computed from the final state of the last stage and stored in its result file."""

    kind: str = text(
        "`granular_collapse`: wall height, runouts, surface RMS error against the Bui et al. (2008) "
        "experiment, failure-line angle; `cohesive_collapse`: back scarp, crest height, toe, plastic zone",
        choices=("granular_collapse", "cohesive_collapse"),
    )
    moved_threshold_m: float = number(
        "m", "a particle whose displacement exceeds this has moved (failure line, back scarp)", gt=0.0
    )
    plastic_strain_threshold: float = number(
        "1", "equivalent plastic strain above which a particle counts in the plastic zone", default=0.01, gt=0.0
    )

    def check_in_study(self, study) -> None:
        """The metrics read a collapse: the last stage dynamic, a wall at x = 0 and a base at y = 0
        (``workflows.collapse.metrics``); ``granular_collapse`` compares with the experiment's column."""
        last = study.stages[-1]
        if last.kind != "dynamic":
            raise StudyError("metrics", f"collapse metrics read the final state of a dynamic stage; the last stage "
                             f"{last.name!r} is a {last.kind} stage")
        xs, ys = zip(*study.geometry.polygon_m)
        tolerance_m = 1e-3 * study.geometry.spacing_m
        if abs(min(xs)) > tolerance_m or abs(min(ys)) > tolerance_m:
            raise StudyError("metrics", f"collapse metrics measure from a wall at x = 0 and a base at y = 0; the "
                             f"domain starts at x = {min(xs):g} m, y = {min(ys):g} m")
        size_m = (max(xs) - min(xs), max(ys) - min(ys))
        if self.kind == "granular_collapse" and not all(
                abs(a - b) <= tolerance_m for a, b in zip(size_m, GRANULAR_COLUMN_M)):
            raise StudyError("metrics.kind", "granular_collapse compares the deposit with the Bui et al. (2008) "
                             f"experiment, a {GRANULAR_COLUMN_M[0]:g} x {GRANULAR_COLUMN_M[1]:g} m column; this "
                             f"domain is {size_m[0]:g} x {size_m[1]:g} m")


@dataclass(frozen=True, kw_only=True)
class Output(Record):
    """What is written beside the result files."""

    figures: bool = boolean(
        "draw PNG figures (a strength-reduction study: the SRF-displacement curve and the fields at the "
        "last stable and first failed SRF)", default=True,
    )
    snapshot_interval_s: float | None = number(
        "s", "write ParaView snapshots of every stage at this interval (`OUT/paraview/<stage>_<k>.vtu` and "
        "`<stage>.pvd`); SRF runs are not snapshotted (`python -m workflows.output.paraview OUT` gives their "
        "final states); default: none", default=None, gt=0.0,
    )
    animation_interval_s: float | None = number(
        "s", "draw an animation of every dynamic and runout stage, a frame per this interval of stage time "
        "(`OUT/<stage>.gif`, 10 frames per second); default: none", default=None, gt=0.0,
    )
    animation_colour: str = text(
        "what colours the particles of the animation", default="plastic_strain",
        choices=("plastic_strain", "displacement"),
    )


MAX_SNAPSHOTS = 2000
"""A stage writes at most this many ParaView snapshots."""
MAX_ANIMATION_FRAMES = 1000
"""An animation has at most this many frames (they are kept in memory until the stage ends)."""

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


@dataclass(frozen=True, kw_only=True)
class Study(Record):
    """A whole study file."""

    study: StudyInfo = table(StudyInfo)
    geometry: Geometry = table(Geometry)
    materials: tuple = tables(
        MATERIAL_MODELS, "materials; a particle takes the last material whose region holds it",
        key="model", key_doc="constitutive model", min_items=1,
    )
    loads: Loads = table(Loads, required=False)
    water: Water | None = optional_table(Water)
    boundary: tuple = tables(Boundary, "prescribed velocities (supports), applied in order")
    walls: tuple = tables(Wall, "rigid walls (segments with friction); none: no contact work at all")
    solver: Solver = table(Solver, required=False)
    stages: tuple = tables(
        STAGE_KINDS, "what to run, in order; each stage continues from the state the previous one left",
        key="kind", key_doc="what the stage does", min_items=1,
    )
    monitors: tuple = tables(Monitor, "points recorded during every stage")
    metrics: Metrics | None = optional_table(Metrics)
    output: Output = table(Output, required=False)
    sweep: Sweep | None = optional_table(Sweep)
    refinement: Refinement | None = optional_table(Refinement)
    probabilistic: Probabilistic | None = optional_table(Probabilistic)
    random_field: RandomField | None = optional_table(RandomField)
    seepage: Seepage | None = optional_table(Seepage)
    source_text: str = dataclasses.field(default="", repr=False, compare=False)
    """The TOML text the study was read from (stored with every result)."""

    @property
    def name(self) -> str:
        return self.study.name

    @property
    def strength_reduction(self) -> StrengthReductionStage | None:
        """The strength-reduction stage (always the last), or None for a plain study."""
        last = self.stages[-1]
        return last if isinstance(last, StrengthReductionStage) else None

    @property
    def slope_height_m(self) -> float:
        """H, the scale of failure: ``strength_reduction.slope_height_m`` if given, else the relief of
        the free surface, the highest minus the lowest point of the polygon's upper boundary (the
        foundation below the toe does not count; ``spfem_core.geometry.relief_m``)."""
        stage = self.strength_reduction
        if stage is not None and stage.slope_height_m is not None:
            return stage.slope_height_m
        return relief_m(self.geometry.polygon_m)

    def check(self):
        for i, stage in enumerate(self.stages):
            stage.check_in_study(self, i)
        known = {b.name for b in self.boundary}
        for i, stage in enumerate(self.stages):
            for name in stage.boundary or ():
                if name not in known:
                    raise StudyError(f"stages[{i}].boundary", f"no [[boundary]] named {name!r} (known: {sorted(known)})")
            if not self.walls and not [b for b in self.boundary if stage.boundary is None or b.name in stage.boundary]:
                field = f"stages[{i}].boundary" if stage.boundary is not None else "boundary"
                raise StudyError(field, f"stage {stage.name!r} has no support and no wall: the body would fall as a "
                                 "whole; give a [[boundary]] (a fixed base, vx_m_s = vy_m_s = 0) and name it here")
        self._check_water_and_loads()
        self._check_frames()
        if self.metrics is not None:
            self.metrics.check_in_study(self)
        if self.geometry.refined and (self.metrics is not None or any(s.kind == "runout" for s in self.stages)):
            raise StudyError("geometry.refined", "refined zones apply to gravity and strength-reduction studies; "
                             "runout and collapse metrics assume one spacing (not yet)")
        if self.random_field is not None:
            self.random_field.check_in_study(self)
        if self.probabilistic is not None:
            if not self.probabilistic.variables and self.random_field is None:
                raise StudyError("probabilistic.variables", "give a random variable, or a [random_field]")
            if self.strength_reduction is None:
                raise StudyError("probabilistic", "a probabilistic study judges each realisation by strength "
                                 "reduction: it needs a strength_reduction stage")
            if self.refinement is not None:
                raise StudyError("probabilistic", "[probabilistic] and [refinement] in one study are not "
                                 "supported yet")
        if self.refinement is not None:
            if self.strength_reduction is None:
                raise StudyError("refinement", "a refinement study computes a factor of safety: it needs a "
                                 "strength_reduction stage")
        for i, monitor in enumerate(self.monitors):
            if not points_in_polygon([(monitor.x_m, monitor.y_m)], self.geometry.polygon_m)[0]:
                raise StudyError(
                    f"monitors[{i}]", f"point ({monitor.x_m:g}, {monitor.y_m:g}) lies outside geometry.polygon_m"
                )

    def _check_water_and_loads(self):
        xs = [x for x, _ in self.geometry.polygon_m]
        x_min, x_max = min(xs), max(xs)
        water = self.water
        lines = [("water.phreatic_line_m", water.phreatic_line_m if water is not None else None)]
        lines += [(f"materials[{i}].phreatic_line_m", m.phreatic_line_m) for i, m in enumerate(self.materials)]
        for field, line in lines:
            if line is not None and (line[0][0] > x_min or line[-1][0] < x_max):
                raise StudyError(field, f"must span the domain's x-range [{x_min:g}, {x_max:g}] m; "
                                 f"it covers [{line[0][0]:g}, {line[-1][0]:g}]")
        study_line = water is not None and water.phreatic_line is not None
        if self.seepage is not None:
            self._check_seepage()
        elif water is not None and not study_line and water.ru is None and water.pond_level_m is None:
            raise StudyError("water.phreatic_line_m", "give phreatic_line_m, phreatic_level_m, ru or pond_level_m "
                             "(or [seepage] to compute the water)")
        for i, material in enumerate(self.materials):
            if self.seepage is not None:
                continue
            if material.saturated_density_kg_m3 is not None and not study_line and material.phreatic_line_m is None:
                raise StudyError(f"materials[{i}].saturated_density_kg_m3", "applies below a piezometric line: give "
                                 "[water] phreatic_line_m or phreatic_level_m, or the material's phreatic_line_m")
            if material.phreatic_line_m is not None and water is not None and water.ru is not None:
                raise StudyError(f"materials[{i}].phreatic_line_m", "give a piezometric line or [water] ru, not both")
        g = math.hypot(*self.loads.gravity_m_s2)
        gamma_w = water.unit_weight_n_m3 if water is not None else 9810.0
        if (water is not None or self.seepage is not None) and g > 0.0:
            for i, material in enumerate(self.materials):
                wet = material.saturated_density_kg_m3 or material.density_kg_m3
                field = "saturated_density_kg_m3" if material.saturated_density_kg_m3 else "density_kg_m3"
                if wet * g <= gamma_w:
                    raise StudyError(f"materials[{i}].{field}", f"{wet:g} kg/m3 is a saturated unit weight of "
                                     f"{wet * g / 1e3:.3g} kN/m3, no more than the water's ({gamma_w / 1e3:.3g} "
                                     "kN/m3): the soil would float (negative buoyant weight); saturated soils are "
                                     "1,600-2,300 kg/m3")
        for where, load in self.loads.surface_loads():
            for field, x in load.abscissae_m().items():
                if not x_min <= x <= x_max:
                    raise StudyError(f"{where}.{field}", f"{x:g} m is off the ground surface, which spans "
                                     f"x = {x_min:g} to {x_max:g} m")
        first = self.stages[0]
        ramp = self.loads.ramp_time_s
        if ramp is not None and ramp > first.time_limit_s:
            raise StudyError("loads.ramp_time_s", f"must be <= the first stage's {first.duration_field} = "
                             f"{first.time_limit_s:g}, got {ramp:g}")
        seismic = self.loads.seismic
        if seismic is not None and not seismic.in_gravity and self.strength_reduction is None:
            raise StudyError("loads.seismic.in_gravity", "false applies the load in strength-reduction runs only, "
                             "and this study has none")

    def _check_seepage(self):
        """[seepage] computes the water: no line or ru beside it, a permeability for every material."""
        water = self.water
        for name in ("phreatic_line_m", "phreatic_level_m", "ru"):
            if water is not None and getattr(water, name) is not None:
                raise StudyError(f"water.{name}", "[seepage] computes the pore pressure: leave the line and ru out")
        for i, material in enumerate(self.materials):
            if material.phreatic_line_m is not None:
                raise StudyError(f"materials[{i}].phreatic_line_m", "[seepage] computes the pore pressure: leave "
                                 "the line out")
            if material.permeability_m_s is None:
                raise StudyError(f"materials[{i}].permeability_m_s", f"{material.name!r} needs a permeability: "
                                 "the study has [seepage]")
        try:
            largest_permeability = max(m.permeability_m_s * max(1.0, m.permeability_ratio) for m in self.materials)
            self.seepage.check_in_study(self.geometry.polygon_m, None if water is None else water.pond_level_m,
                                        largest_permeability)
        except StudyError as error:
            raise StudyError(f"seepage.{error.field}", error.problem) from None

    def _check_frames(self):
        snapshotted = [s for s in self.stages if s.snapshotted]
        animated = [s for s in self.stages if s.animated]
        for name, limit, stages in (("snapshot_interval_s", MAX_SNAPSHOTS, snapshotted),
                                    ("animation_interval_s", MAX_ANIMATION_FRAMES, animated)):
            interval = getattr(self.output, name)
            longest = max((stage.time_limit_s for stage in stages), default=0.0)
            if interval is not None and longest / interval > limit:
                raise StudyError(f"output.{name}", f"{interval:g} s gives {longest / interval:.3g} frames over the "
                                 f"longest stage ({longest:g} s), more than {limit}")
