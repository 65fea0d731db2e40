"""The tables of a study file, one frozen dataclass each, and the whole :class:`Study`.

Arrays of tables whose entries come in kinds (``[[stages]]`` with ``kind``,
``[[materials]]`` with ``model``) map each kind to its own dataclass, so a new kind
(a ``drucker_prager`` material, a ``strength_reduction`` stage) is one more class.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

from workflows.study.fields import (
    Record,
    StudyError,
    any_values,
    boolean,
    integer,
    name_field,
    names,
    number,
    numbers,
    optional_table,
    point,
    point_in_polygon,
    polygon,
    polyline,
    table,
    tables,
    text,
)


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
class Geometry(Record):
    """The domain and its particle cloud: a polygon (given, or made by [geometry.slope]) filled with
    particles at spacing h."""

    polygon_m: tuple | None = polygon(
        "m", "outline of the domain, [[x, y], ...], either orientation, not closed; give polygon_m or "
        "[geometry.slope]", default=None,
    )
    spacing_m: float = number("m", "particle spacing h of the lattice clipped to the polygon", gt=0.0)
    jitter: float = number(  # lt: spfem_core.cloud.MAX_JITTER (not imported: it would import numba)
        "1", "random offset of interior particles, as a fraction of h", default=0.0, ge=0.0, lt=0.3
    )
    seed: int = integer("seed of the random jitter", default=0, ge=0)
    slope: SlopeForm | None = optional_table(SlopeForm)

    def check(self):
        if self.polygon_m is None:
            raise StudyError("polygon_m", "required field missing (or give a [geometry.slope] table)")
        xs, ys = [x for x, _ in self.polygon_m], [y for _, y in self.polygon_m]
        extent = min(max(xs) - min(xs), max(ys) - min(ys))
        if self.spacing_m > 0.5 * extent:
            raise StudyError("spacing_m", f"{self.spacing_m:g} m is more than half the domain's smaller extent "
                             f"({extent:g} m): too few particles across it")


@dataclass(frozen=True, kw_only=True)
class MaterialBase(Record):
    """Fields shared by every material model."""

    model: ClassVar[str]
    name: str = name_field("name of the material")
    density_kg_m3: float = number("kg m-3", "mass density rho", ge=1.0)
    youngs_modulus_pa: float = number("Pa", "Young's modulus E", ge=1.0)
    poisson_ratio: float = number("1", "Poisson's ratio nu", ge=0.0, lt=0.5)
    region_m: tuple | None = polygon(
        "m", "polygon of the particles that get this material; default: the whole domain; "
        "later materials override earlier ones", default=None
    )
    saturated_density_kg_m3: float | None = number(
        "kg m-3", "mass density at or below the piezometric line; default density_kg_m3 (one total unit "
        "weight above and below)", default=None, ge=1.0,
    )
    phreatic_line_m: tuple | None = polyline(
        "m", "this material's own piezometric line [[x, y], ...] (a perched water table), instead of [water]'s; "
        "x increasing, spanning the domain", default=None,
    )


@dataclass(frozen=True, kw_only=True)
class ElasticMaterial(MaterialBase):
    """Linear elastic, plane strain."""

    model: ClassVar[str] = "elastic"


@dataclass(frozen=True, kw_only=True)
class StrengthMixin(Record):
    """Shear strength (c, phi, psi) of a perfectly plastic material."""

    cohesion_pa: float = number("Pa", "cohesion c", ge=0.0)
    friction_deg: float = number("degree", "friction angle phi", ge=0.0, lt=90.0)
    dilation_deg: float = number("degree", "dilation angle psi (<= phi); 0: no plastic volume change", default=0.0, ge=0.0)
    tensile_strength_pa: float | None = number(
        "Pa", "tension cut-off sigma_t: Mohr-Coulomb caps the largest principal stress, Drucker-Prager the mean "
        "stress, at sigma_t (reduced with c in strength reduction); default: none (the yield surface's own apex, "
        "c cot phi)", default=None, ge=0.0,
    )

    def check(self):
        if self.dilation_deg > self.friction_deg:
            raise StudyError("dilation_deg", f"must be <= friction_deg = {self.friction_deg:g}, got {self.dilation_deg:g}")
        if self.cohesion_pa == 0.0 and self.friction_deg == 0.0:
            raise StudyError("cohesion_pa", "a material with c = 0 and phi = 0 has no strength")


DP_FIT_CHOICES = ("mohr_coulomb_match", "inner", "outer", "plane_strain_associated", "plane_strain_nonassociated")


@dataclass(frozen=True, kw_only=True)
class DruckerPragerMaterial(StrengthMixin, MaterialBase):
    """Drucker-Prager, perfectly plastic, plane strain; the fit sets its match to Mohr-Coulomb."""

    model: ClassVar[str] = "drucker_prager"
    dp_fit: str = text(
        "cone fitted to Mohr-Coulomb: `mohr_coulomb_match` picks the plane-strain fit that reproduces "
        "Mohr-Coulomb at collapse for the given dilation; `inner` is ESPFEM2D's",
        default="mohr_coulomb_match", choices=DP_FIT_CHOICES,
    )


@dataclass(frozen=True, kw_only=True)
class MohrCoulombMaterial(StrengthMixin, MaterialBase):
    """Mohr-Coulomb, plane strain (return map in principal stresses), perfectly plastic or softening from
    peak (cohesion_pa, friction_deg) to residual strength with the equivalent plastic strain."""

    model: ClassVar[str] = "mohr_coulomb"
    softening: str = text(
        "strain softening from peak to residual strength: `none`, `linear` (from softening_start_strain to "
        "softening_end_strain) or `exponential` (1 - exp(-3 (eps - start) / (end - start)) of the drop)",
        default="none", choices=("none", "linear", "exponential"),
    )
    residual_cohesion_pa: float | None = number("Pa", "*softening:* residual cohesion c_r; default cohesion_pa",
                                                default=None, ge=0.0)
    residual_friction_deg: float | None = number("degree", "*softening:* residual friction angle phi_r; default "
                                                 "friction_deg", default=None, ge=0.0, lt=90.0)
    softening_start_strain: float = number("1", "*softening:* equivalent plastic strain where the strength starts "
                                           "to fall", default=0.0, ge=0.0)
    softening_end_strain: float | None = number("1", "*softening:* equivalent plastic strain where it reaches the "
                                                "residual (exponential: 95% of the drop)", default=None, gt=0.0)

    def check(self):
        super().check()
        given = [name for name in ("residual_cohesion_pa", "residual_friction_deg", "softening_end_strain")
                 if getattr(self, name) is not None]
        if self.softening == "none":
            if given:
                raise StudyError(given[0], "applies with softening = linear or exponential only")
            return
        if self.softening_end_strain is None:
            raise StudyError("softening_end_strain", "required with softening")
        if self.softening_end_strain <= self.softening_start_strain:
            raise StudyError("softening_end_strain", f"must be > softening_start_strain = "
                             f"{self.softening_start_strain:g}, got {self.softening_end_strain:g}")
        if self.residual_cohesion_or_peak > self.cohesion_pa:
            raise StudyError("residual_cohesion_pa", f"must be <= cohesion_pa = {self.cohesion_pa:g}")
        if self.residual_friction_or_peak > self.friction_deg:
            raise StudyError("residual_friction_deg", f"must be <= friction_deg = {self.friction_deg:g}")
        if self.residual_cohesion_or_peak == 0.0 and self.residual_friction_or_peak == 0.0:
            raise StudyError("residual_cohesion_pa", "a residual strength of c = 0 and phi = 0 is no strength")

    @property
    def residual_cohesion_or_peak(self) -> float:
        return self.cohesion_pa if self.residual_cohesion_pa is None else self.residual_cohesion_pa

    @property
    def residual_friction_or_peak(self) -> float:
        return self.friction_deg if self.residual_friction_deg is None else self.residual_friction_deg


MATERIAL_MODELS: dict[str, type[MaterialBase]] = {
    "elastic": ElasticMaterial,
    "drucker_prager": DruckerPragerMaterial,
    "mohr_coulomb": MohrCoulombMaterial,
}


@dataclass(frozen=True, kw_only=True)
class Seismic(Record):
    """Pseudo-static earthquake load: body forces kh g horizontally and kv g vertically (g = |gravity|),
    from the first stage on (or in the strength-reduction runs only)."""

    horizontal_coefficient: float = number("1", "kh: horizontal body force kh g per unit mass, towards direction",
                                           ge=0.0, lt=1.0)
    vertical_coefficient: float = number(
        "1", "kv: vertical body force kv g per unit mass, upward for kv > 0 (the soil weighs (1 - kv) g), downward "
        "for kv < 0", default=0.0, gt=-1.0, lt=1.0,
    )
    direction: str = text(
        "direction of the horizontal force: `out_of_slope` (towards the side where the ground surface is lower, "
        "the free face), `+x` or `-x`", default="out_of_slope", choices=("out_of_slope", "+x", "-x"),
    )
    in_gravity: bool = boolean(
        "apply it in the stages before the strength reduction too, so that every SRF run starts in equilibrium "
        "with it and moves by the strength reduction alone; false: only in the SRF runs, which then also carry "
        "the elastic response to the load suddenly applied", default=True,
    )


@dataclass(frozen=True, kw_only=True)
class StripLoad(Record):
    """A uniform vertical pressure on the ground surface between two abscissae (a footing, a surcharge),
    carried by the surface particles from the first stage on."""

    name: str = name_field("name of the load")
    x_start_m: float = number("m", "left end of the loaded strip")
    x_end_m: float = number("m", "right end of the loaded strip")
    pressure_pa: float = number("Pa", "pressure q, downward, per metre of horizontal length", gt=0.0)

    def check(self):
        if not self.x_end_m > self.x_start_m:
            raise StudyError("x_end_m", f"must be > x_start_m = {self.x_start_m:g}, got {self.x_end_m:g}")


@dataclass(frozen=True, kw_only=True)
class LineLoad(Record):
    """A vertical force at one point of the ground surface (per metre of thickness), carried by the
    surface particles there from the first stage on."""

    name: str = name_field("name of the load")
    x_m: float = number("m", "abscissa of the point on the ground surface")
    force_n_m: float = number("N m-1", "force, downward, per metre of out-of-plane thickness", gt=0.0)


@dataclass(frozen=True, kw_only=True)
class Loads(Record):
    """Body forces and surface loads, applied from the start of the first stage (the seismic load:
    see [loads.seismic])."""

    gravity_m_s2: tuple = point("m s-2", "gravitational acceleration [gx, gy]", default=(0.0, -9.81))
    seismic: Seismic | None = optional_table(Seismic)
    strip: tuple = tables(StripLoad, "uniform pressures on the ground surface")
    line: tuple = tables(LineLoad, "point forces on the ground surface")
    ramp_time_s: float | None = number(
        "s", "the strip and line loads grow linearly from zero over this time at the start of the first stage "
        "(a relaxation does not converge before it ends); default: applied at once", default=None, gt=0.0,
    )


@dataclass(frozen=True, kw_only=True)
class Water(Record):
    """Ground water, drained and steady: a piezometric line (or ru) sets the pore pressure in the ground,
    ponded water loads its surface.  The line is fixed in space while the ground deforms."""

    unit_weight_n_m3: float = number("N m-3", "unit weight gamma_w of water", default=9810.0, gt=0.0)
    phreatic_line_m: tuple | None = polyline(
        "m", "piezometric line [[x, y], ...], x increasing, spanning the domain: u = gamma_w (y_line - y) below "
        "it, 0 above; give phreatic_line_m, phreatic_level_m or ru", default=None,
    )
    phreatic_level_m: float | None = number(
        "m", "a horizontal piezometric line at this height, instead of phreatic_line_m", default=None,
    )
    ru: float | None = number(
        "1", "pore pressure ratio: u = ru sigma_v0, the vertical total stress of the overburden at the "
        "particle's initial position (carried by the particle)", default=None, ge=0.0, lt=1.0,
    )
    pond_level_m: float | None = number(
        "m", "level of water standing on the ground surface: the submerged surface carries gamma_w (level - y) "
        "normal to it, on the current boundary; default: none", default=None,
    )

    def check(self):
        given = [name for name in ("phreatic_line_m", "phreatic_level_m", "ru") if getattr(self, name) is not None]
        if len(given) > 1:
            raise StudyError(given[1], f"give one of phreatic_line_m, phreatic_level_m and ru, not {given[0]} too")
        if not given and self.pond_level_m is None:
            raise StudyError("phreatic_line_m", "give phreatic_line_m, phreatic_level_m, ru or pond_level_m")

    @property
    def phreatic_line(self) -> tuple | None:
        """The piezometric line as points, or None (a level spans any domain: its ends at +-1e9 m)."""
        if self.phreatic_level_m is not None:
            return ((-1e9, self.phreatic_level_m), (1e9, self.phreatic_level_m))
        return self.phreatic_line_m


@dataclass(frozen=True, kw_only=True)
class Boundary(Record):
    """Prescribed velocity on the particles initially inside a box (closed, tolerance h/1000).

    A missing bound leaves the box open on that side; a missing velocity leaves that
    direction free (vx = 0 alone is a roller).
    """

    name: str = name_field("name of the boundary condition")
    x_min_m: float | None = number("m", "left side of the box; default: unbounded", default=None)
    x_max_m: float | None = number("m", "right side of the box; default: unbounded", default=None)
    y_min_m: float | None = number("m", "bottom of the box; default: unbounded", default=None)
    y_max_m: float | None = number("m", "top of the box; default: unbounded", default=None)
    vx_m_s: float | None = number("m s-1", "prescribed x velocity; default: free", default=None)
    vy_m_s: float | None = number("m s-1", "prescribed y velocity; default: free", default=None)

    def check(self):
        if self.vx_m_s is None and self.vy_m_s is None:
            raise StudyError("vx_m_s", "give vx_m_s, vy_m_s or both (a boundary must prescribe something)")
        for axis in "xy":
            low, high = getattr(self, f"{axis}_min_m"), getattr(self, f"{axis}_max_m")
            if low is not None and high is not None and low > high:
                raise StudyError(f"{axis}_max_m", f"must be >= {axis}_min_m = {low:g}, got {high:g}")


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


DEFAULT_CFL = 0.5


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
        "1", "rank-deficiency stabilisation factor beta; 0 switches it off", default=0.1, ge=0.0
    )
    alpha: float = number(
        "1", "alpha-shape factor: triangles with circumradius > alpha h are dropped", default=1.5, ge=1.0, le=3.0
    )
    remesh_min_angle_deg: float = number(
        "degree", "rebuild the mesh when its smallest angle falls below this; after each rebuild the "
        "threshold is the fresh mesh's smallest angle less 5 degrees (or half of it, if that is larger), "
        "never above this", default=20.0, gt=0.0, lt=60.0,
    )

    def check(self):
        if self.cfl is not None and self.dt_s is not None:
            raise StudyError("dt_s", "give cfl or dt_s, not both")


@dataclass(frozen=True, kw_only=True)
class StageBase(Record):
    """Fields shared by every kind of stage."""

    kind: ClassVar[str]
    duration_field: ClassVar[str]  # the field that bounds how long the stage runs
    name: str = name_field("name of the stage; names the result file when a study has several stages")
    record_interval_s: float = number("s", "time between two records of the monitors", gt=0.0)
    elastic: bool = boolean("treat every material as linear elastic in this stage (a gravity stage)", default=False)
    boundary: tuple | None = names("names of the [[boundary]] entries active in this stage; default: all", default=None)
    start: str = text(
        "`original_positions`: start at rest at the initial positions with the stresses the previous "
        "stage left (displacements discarded); `continue`: carry on from the previous stage's state",
        default="original_positions", choices=("original_positions", "continue"),
    )

    def check(self):
        limit = getattr(self, self.duration_field)
        if self.record_interval_s > limit:
            problem = f"must be <= {self.duration_field} = {limit:g}, got {self.record_interval_s:g}"
            raise StudyError("record_interval_s", problem)


@dataclass(frozen=True, kw_only=True)
class DynamicStage(StageBase):
    """Explicit dynamics for a fixed duration."""

    kind: ClassVar[str] = "dynamic"
    duration_field: ClassVar[str] = "duration_s"
    duration_s: float = number("s", "simulated time of the stage", gt=0.0)
    damping: float = number(
        "1", "local (Cundall) damping factor; 0 is undamped dynamics", default=0.0, ge=0.0, lt=1.0
    )


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


DEFAULT_REST_KINETIC_FRACTION = 1e-3
DEFAULT_RUNOUT_REST_WINDOW_S = 0.5


@dataclass(frozen=True, kw_only=True)
class RunoutStage(StageBase):
    """Runout after failure: explicit dynamics with the strength divided by a factor, from the previous
    stage's stresses, until the flow is at rest or max_duration_s; the result file carries the runout
    metrics (runout, retrogression, sliding mass, speeds, energy budget, final surface)."""

    kind: ClassVar[str] = "runout"
    duration_field: ClassVar[str] = "max_duration_s"
    max_duration_s: float = number("s", "stop here if the flow has not come to rest", gt=0.0)
    strength_factor: float = number(
        "1", "the strength at the start of the stage is c / F and tan(phi) / F (dilation min(psi, phi_F)); "
        "1: as declared (with softening, the flow comes from it)", default=1.0, gt=0.0,
    )
    damping: float = number("1", "local (Cundall) damping factor; 0 is undamped dynamics", default=0.0, ge=0.0,
                            lt=1.0)
    rest_fraction: float = number(
        "1", "at rest: kinetic energy below this fraction of the potential energy released so far, sustained over "
        "rest_window_s", default=DEFAULT_REST_KINETIC_FRACTION, gt=0.0, lt=1.0,
    )
    rest_window_s: float = number("s", "see rest_fraction", default=DEFAULT_RUNOUT_REST_WINDOW_S, gt=0.0)
    deposit_thickness_m: float | None = number(
        "m", "the surface counts as raised (runout) or lowered (retrogression) where it moved more than this from "
        "the initial surface; default 2% of the slope height", default=None, gt=0.0,
    )
    moved_threshold_m: float | None = number(
        "m", "a particle that moved more than this belongs to the sliding mass; default 1% of the slope height",
        default=None, gt=0.0,
    )
    horizontal_coefficient: float | None = number(
        "1", "trigger: a horizontal seismic coefficient kh acting out of the slope from the start of this stage "
        "(instead of [loads.seismic]); default: the study's loads", default=None, ge=0.0, lt=1.0,
    )
    phreatic_level_m: float | None = number(
        "m", "trigger: a horizontal piezometric line at this height from the start of this stage (a water-level "
        "change; materials with their own line keep it); default: the study's [water]", default=None,
    )
    pond_level_m: float | None = number(
        "m", "trigger: ponded water at this level from the start of this stage; default: the study's [water]",
        default=None,
    )

    def check(self):
        super().check()
        if self.elastic:
            raise StudyError("elastic", "must be false: a runout stage needs a plastic material")


PROTOCOLS = ("quasi_static", "ramp", "sudden")
FLOW_RULES = ("associated", "as_declared")
DEFAULT_QUASI_STATIC_DAMPING = 0.7
DEFAULT_QUASI_STATIC_TOLERANCE = 1e-5
DEFAULT_REST_WINDOW_S = 1.0
DEFAULT_REST_GROWTH = 0.01


@dataclass(frozen=True, kw_only=True)
class StrengthReductionStage(StageBase):
    """Strength reduction: one run per SRF F from the previous stage's stresses with c / F and
    tan(phi) / F; the FOS is where the SRF-displacement curve turns up (last stage only)."""

    kind: ClassVar[str] = "strength_reduction"
    duration_field: ClassVar[str] = "duration_s"
    duration_s: float = number(
        "s", "longest simulated time of each SRF run; with early_stop a run ends once at rest or once it has "
        "slid 10% of the slope height", gt=0.0,
    )
    protocol: str = text(
        "how the strength is reduced: `quasi_static`: at once, with local damping, each run until the "
        "unbalanced force converges (a slope at rest) or the slope slides; `ramp`: gradually over ramp_time_s, "
        "undamped; `sudden`: at once, undamped (docs/verification.md compares them)",
        default="quasi_static", choices=PROTOCOLS,
    )
    damping: float | None = number(
        "1", "*protocol = quasi_static:* local (Cundall) damping factor; default 0.7", default=None, gt=0.0, lt=1.0,
    )
    tolerance: float | None = number(
        "1", "*protocol = quasi_static:* at rest once the unbalanced-force ratio is below this; default 1e-05",
        default=None, gt=0.0, lt=1.0,
    )
    ramp_time_s: float | None = number(
        "s", "*protocol = ramp:* the strength falls from full to c / F, tan(phi) / F over this time; default "
        "4 response times of the slope, 16 H_domain / V_s", default=None, gt=0.0,
    )
    flow_rule: str = text(
        "`associated`: the dilation follows the reduced friction, psi_F = phi_F, the flow rule under which limit "
        "equilibrium and limit analysis give the FOS; `as_declared`: psi_F = min(psi, phi_F) with each "
        "material's dilation_deg (psi = 0 gives a lower FOS, about 2% at phi = 20 deg)",
        default="associated", choices=FLOW_RULES,
    )
    srf_min: float = number(
        "1", "first SRF of the sweep; below 1 tests whether the slope stands as built", ge=0.01,
    )
    srf_max: float = number("1", "last SRF of the sweep", gt=0.0)
    srf_step: float = number(
        "1", "SRF step of the first sweep (refined around the knee afterwards; SRF values are rounded to 1e-4)",
        ge=0.001,
    )
    fos_tolerance: float = number(
        "1", "refine until the FOS bracket is at most this wide", default=0.01, gt=0.0
    )
    max_runs: int = integer("never make more SRF runs than this", default=40, ge=3, le=1000)
    slope_height_m: float | None = number(
        "m", "height H of the slope, the scale of failure; default: the relief of the free surface, the highest "
        "minus the lowest point of the polygon's upper boundary (crest above toe)", default=None, gt=0.0,
    )
    failure_displacement_m: float | None = number(
        "m", "a run whose largest displacement exceeds this has failed: a mechanism formed and moved; "
        "default: 0.5% of the slope height", default=None, gt=0.0,
    )
    displacement_floor_m: float | None = number(
        "m", "displacements below this count as this in the log-scale curve (no mechanism); "
        "default: failure_displacement_m / 1000", default=None, gt=0.0,
    )
    rest_window_s: float | None = number(
        "s", "*protocol = ramp or sudden:* at rest: the largest displacement grew by less than rest_growth of "
        "itself over the last window, and by less than over the window before; default 1.0", default=None,
        gt=0.0,
    )
    rest_growth: float | None = number(
        "1", "*protocol = ramp or sudden:* see rest_window_s; default 0.01", default=None, gt=0.0, lt=1.0,
    )
    early_stop: bool = boolean(
        "end a run once it is at rest or once it has slid 10% of the slope height", default=True,
    )

    def check(self):
        super().check()
        if self.srf_max < self.srf_min:
            raise StudyError("srf_max", f"must be >= srf_min = {self.srf_min:g}, got {self.srf_max:g}")
        if self.srf_step > self.srf_max - self.srf_min and self.srf_max > self.srf_min:
            raise StudyError("srf_step", f"must be <= srf_max - srf_min = {self.srf_max - self.srf_min:g}")
        if (self.srf_max - self.srf_min) / self.srf_step > 200:
            raise StudyError("srf_step", "gives more than 200 sweep values; use a coarser step (the knee is refined)")
        if self.elastic:
            raise StudyError("elastic", "must be false: a strength-reduction stage needs a plastic material")
        if self.start != "original_positions":
            raise StudyError("start", "must be 'original_positions': every SRF run starts from the gravity state")
        applies = {"damping": ("quasi_static",), "tolerance": ("quasi_static",), "ramp_time_s": ("ramp",),
                   "rest_window_s": ("ramp", "sudden"), "rest_growth": ("ramp", "sudden")}
        for name, protocols in applies.items():
            if getattr(self, name) is not None and self.protocol not in protocols:
                raise StudyError(name, f"applies to protocol = {' or '.join(protocols)} only, not {self.protocol}")
        if self.protocol != "quasi_static" and self.early_stop and 2 * self.rest_window_s_or_default > self.duration_s:
            raise StudyError(
                "rest_window_s",
                f"must be <= duration_s / 2 = {self.duration_s / 2:g}, got {self.rest_window_s_or_default:g}",
            )
        if self.protocol == "ramp" and self.ramp_time_s is not None and self.ramp_time_s >= self.duration_s:
            raise StudyError("ramp_time_s", f"must be < duration_s = {self.duration_s:g}, got {self.ramp_time_s:g}")
        if (
            self.failure_displacement_m is not None
            and self.displacement_floor_m is not None
            and self.displacement_floor_m >= self.failure_displacement_m
        ):
            raise StudyError("displacement_floor_m", "must be < failure_displacement_m")

    @property
    def rest_window_s_or_default(self) -> float:
        return DEFAULT_REST_WINDOW_S if self.rest_window_s is None else self.rest_window_s

    @property
    def rest_growth_or_default(self) -> float:
        return DEFAULT_REST_GROWTH if self.rest_growth is None else self.rest_growth

    @property
    def damping_or_default(self) -> float:
        return DEFAULT_QUASI_STATIC_DAMPING if self.damping is None else self.damping

    @property
    def tolerance_or_default(self) -> float:
        return DEFAULT_QUASI_STATIC_TOLERANCE if self.tolerance is None else self.tolerance


STAGE_KINDS: dict[str, type[StageBase]] = {
    "dynamic": DynamicStage,
    "relaxation": RelaxationStage,
    "runout": RunoutStage,
    "strength_reduction": StrengthReductionStage,
}


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
    source_text: str = dataclasses.field(default="", repr=False, compare=False)
    """The TOML text the study was read from (stored with every result)."""

    @property
    def name(self) -> str:
        return self.study.name

    @property
    def strength_reduction(self) -> "StrengthReductionStage | None":
        """The strength-reduction stage (always the last), or None for a plain study."""
        last = self.stages[-1]
        return last if isinstance(last, StrengthReductionStage) else None

    def check(self):
        for i, stage in enumerate(self.stages):
            if isinstance(stage, StrengthReductionStage):
                if i != len(self.stages) - 1:
                    raise StudyError(f"stages[{i}].kind", "a strength_reduction stage must be the last stage")
                if i == 0:
                    raise StudyError(
                        f"stages[{i}].kind",
                        "a strength_reduction stage starts from a gravity state: put a relaxation stage before it",
                    )
                if not any(m.model != "elastic" for m in self.materials):
                    raise StudyError("materials", "a strength_reduction stage needs a material with strength (c, phi)")
        if self.strength_reduction is not None and any(isinstance(stage, RunoutStage) for stage in self.stages):
            raise StudyError("stages", "runout stages and a strength_reduction stage belong in separate studies")
        if self.metrics is not None and self.strength_reduction is not None:
            raise StudyError("metrics", "collapse metrics do not apply to a strength_reduction study")
        known = {b.name for b in self.boundary}
        for i, stage in enumerate(self.stages):
            for name in stage.boundary or ():
                if name not in known:
                    raise StudyError(f"stages[{i}].boundary", f"no [[boundary]] named {name!r} (known: {sorted(known)})")
        self._check_water_and_loads()
        self._check_frames()
        for i, monitor in enumerate(self.monitors):
            if not point_in_polygon((monitor.x_m, monitor.y_m), self.geometry.polygon_m):
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
        for i, material in enumerate(self.materials):
            if material.saturated_density_kg_m3 is not None and not study_line and material.phreatic_line_m is None:
                raise StudyError(f"materials[{i}].saturated_density_kg_m3", "applies below a piezometric line: give "
                                 "[water] phreatic_line_m or phreatic_level_m, or the material's phreatic_line_m")
            if material.phreatic_line_m is not None and water is not None and water.ru is not None:
                raise StudyError(f"materials[{i}].phreatic_line_m", "give a piezometric line or [water] ru, not both")
        for kind, loads in (("strip", self.loads.strip), ("line", self.loads.line)):
            for i, load in enumerate(loads):
                ends = (load.x_start_m, load.x_end_m) if kind == "strip" else (load.x_m,)
                for end in ends:
                    if not x_min <= end <= x_max:
                        field = "x_m" if kind == "line" else ("x_start_m" if end == load.x_start_m else "x_end_m")
                        raise StudyError(f"loads.{kind}[{i}].{field}", f"{end:g} m is off the ground surface, which "
                                         f"spans x = {x_min:g} to {x_max:g} m")
        first = self.stages[0]
        ramp = self.loads.ramp_time_s
        if ramp is not None and ramp > getattr(first, first.duration_field):
            raise StudyError("loads.ramp_time_s", f"must be <= the first stage's {first.duration_field} = "
                             f"{getattr(first, first.duration_field):g}, got {ramp:g}")
        seismic = self.loads.seismic
        if seismic is not None and not seismic.in_gravity and self.strength_reduction is None:
            raise StudyError("loads.seismic.in_gravity", "false applies the load in strength-reduction runs only, "
                             "and this study has none")

    def _check_frames(self):
        snapshotted = [s for s in self.stages if not isinstance(s, StrengthReductionStage)]
        animated = [s for s in self.stages if isinstance(s, (DynamicStage, RunoutStage))]
        for name, limit, stages in (("snapshot_interval_s", MAX_SNAPSHOTS, snapshotted),
                                    ("animation_interval_s", MAX_ANIMATION_FRAMES, animated)):
            interval = getattr(self.output, name)
            longest = max((getattr(stage, stage.duration_field) for stage in stages), default=0.0)
            if interval is not None and longest / interval > limit:
                raise StudyError(f"output.{name}", f"{interval:g} s gives {longest / interval:.3g} frames over the "
                                 f"longest stage ({longest:g} s), more than {limit}")
