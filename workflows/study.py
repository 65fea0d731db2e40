"""The study file: one TOML file that describes a simulation, checked before anything runs.

Every field is declared once, on the frozen dataclass of its table, with its type, unit,
default, bounds and documentation (``number``, ``integer``, ``text``, ``point``,
``polygon``, ``table``, ``tables`` below).  From that one declaration come

- the checks of :func:`load_study` / :func:`parse_study`, which raise :class:`StudyError`
  with a one-line message ``<field path>: <problem>``;
- the JSON schema and the Markdown reference (``python -m workflows.study --json-schema``
  or ``--markdown``, see :mod:`workflows.schema_docs`).

A study file is data only: it is read with :mod:`tomllib` and never executes code.

Arrays of tables whose entries come in kinds (``[[stages]]`` with ``kind``,
``[[materials]]`` with ``model``) map each kind to its own dataclass, so a new kind
(a ``drucker_prager`` material, a ``strength_reduction`` stage) is one more class.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"
"""Names of studies, stages, materials, boundaries and monitors: they become folder,
file and coordinate names, so letters, digits, ``_``, ``.`` and ``-`` only."""

REQUIRED = dataclasses.MISSING


class StudyError(ValueError):
    """A study file that cannot be run; ``str()`` is one line ``<field>: <problem>``."""

    def __init__(self, field: str, problem: str):
        self.field = field
        self.problem = " ".join(str(problem).split())
        super().__init__(f"{field}: {self.problem}" if field else self.problem)


# ---------------------------------------------------------------------------------------
# How a field is declared
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Spec:
    """How one field of a study file is written, checked and documented.

    ``type`` is one of ``number`` (a float; an integer is accepted, a boolean is not),
    ``integer``, ``text``, ``point`` ([x, y]), ``polygon`` ([[x, y], ...]), ``table``
    (one nested table, class ``of``) or ``tables`` (an array of tables: ``of`` is a
    class, or a dict from the value of the ``key`` field to a class).
    """

    type: str
    unit: str = ""
    doc: str = ""
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple[str, ...] = ()
    pattern: str | None = None
    of: Any = None
    key: str | None = None
    key_doc: str = ""
    min_items: int = 0

    @property
    def bounds(self) -> list[tuple[str, float]]:
        """The bounds that apply, as (operator, value) pairs."""
        pairs = [(">", self.gt), (">=", self.ge), ("<", self.lt), ("<=", self.le)]
        return [(op, value) for op, value in pairs if value is not None]

    @property
    def variants(self) -> dict[str, type]:
        """For ``tables`` with a ``key``: kind -> dataclass; otherwise {}."""
        return dict(self.of) if isinstance(self.of, dict) else {}


def _declare(spec: Spec, default=REQUIRED, default_factory=REQUIRED):
    return dataclasses.field(default=default, default_factory=default_factory, metadata={"spec": spec})


def number(unit, doc, *, default=REQUIRED, gt=None, ge=None, lt=None, le=None):
    """A finite float field (``unit`` "1" for a dimensionless number)."""
    return _declare(Spec("number", unit, doc, gt=gt, ge=ge, lt=lt, le=le), default)


def integer(doc, *, default=REQUIRED, ge=None, le=None):
    """An integer field."""
    return _declare(Spec("integer", "1", doc, ge=ge, le=le), default)


def text(doc, *, default=REQUIRED, choices=(), pattern=None):
    """A string field, optionally limited to ``choices`` or a regular expression."""
    return _declare(Spec("text", "", doc, choices=tuple(choices), pattern=pattern), default)


def boolean(doc, *, default=REQUIRED):
    """A true/false field."""
    return _declare(Spec("boolean", "", doc), default)


def names(doc, *, default=REQUIRED):
    """A list of names (of other entries of the study), e.g. ["base", "left"]."""
    return _declare(Spec("names", "", doc), default)


def name_field(doc):
    """A required name made of letters, digits, ``_``, ``.`` and ``-``."""
    return text(doc, pattern=NAME_PATTERN)


def point(unit, doc, *, default=REQUIRED):
    """A pair of numbers [x, y]."""
    return _declare(Spec("point", unit, doc), default)


def polygon(unit, doc, *, default=REQUIRED):
    """A simple polygon [[x, y], ...]: at least 3 vertices, non-zero area, no crossing edges."""
    return _declare(Spec("polygon", unit, doc), default)


def table(of: type, *, required: bool = True):
    """A nested table ``[name]`` described by the dataclass ``of`` (its docstring documents it)."""
    spec = Spec("table", doc=_first_line(of.__doc__), of=of)
    return _declare(spec) if required else _declare(spec, default_factory=of)


def tables(of, doc, *, key=None, key_doc="", min_items=0):
    """An array of tables ``[[name]]``; entries need unique ``name`` fields.

    ``of`` is a dataclass, or with ``key`` a dict from the value of that field to the
    dataclass of that kind of entry.
    """
    spec = Spec("tables", doc=doc, of=of, key=key, key_doc=key_doc, min_items=min_items)
    return _declare(spec, default=() if min_items == 0 else REQUIRED)


def specs(cls) -> dict[str, Spec]:
    """The declared fields of a study dataclass, in order (undeclared fields excluded)."""
    return {f.name: f.metadata["spec"] for f in dataclasses.fields(cls) if "spec" in f.metadata}


def field_default(cls, field_name: str):
    """The default of a declared field: a value, or ``REQUIRED``."""
    f = next(f for f in dataclasses.fields(cls) if f.name == field_name)
    if f.default is not REQUIRED:
        return f.default
    if f.default_factory is not REQUIRED:
        return f.default_factory()
    return REQUIRED


def _first_line(doc: str | None) -> str:
    return (doc or "").strip().splitlines()[0] if doc else ""


# ---------------------------------------------------------------------------------------
# Checking one value against its declaration
# ---------------------------------------------------------------------------------------


def show(value) -> str:
    """A value as it would look in TOML, shortened for error messages."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (list, tuple)):
        shown = "[" + ", ".join(show(v) for v in value) + "]"
        return shown if len(shown) <= 60 else shown[:56] + " ...]"
    if value is None:
        return "nothing"
    return repr(value) if isinstance(value, float) else str(value)


def _as_number(value, what="must be a number") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = " (a boolean)" if isinstance(value, bool) else ""
        raise ValueError(f"{what}, got {show(value)}{kind}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"must be finite, got {show(value)}")
    return x


def _as_pair(value, what: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"{what} must be a pair of numbers [x, y], got {show(value)}")
    return (_as_number(value[0], f"{what} must be numbers"), _as_number(value[1], f"{what} must be numbers"))


def polygon_area(vertices) -> float:
    """Signed area (shoelace formula), positive for counter-clockwise vertices."""
    n = len(vertices)
    return 0.5 * sum(
        vertices[i][0] * vertices[(i + 1) % n][1] - vertices[(i + 1) % n][0] * vertices[i][1] for i in range(n)
    )


def _segments_cross(p1, p2, q1, q2) -> bool:
    """True when the closed segments p1-p2 and q1-q2 intersect."""

    def orient(a, b, c):
        value = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return (value > 0) - (value < 0)

    def on_segment(a, b, c):  # c collinear with a-b: is it between them?
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    o1, o2, o3, o4 = orient(p1, p2, q1), orient(p1, p2, q2), orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4:
        return True
    return (
        (o1 == 0 and on_segment(p1, p2, q1))
        or (o2 == 0 and on_segment(p1, p2, q2))
        or (o3 == 0 and on_segment(q1, q2, p1))
        or (o4 == 0 and on_segment(q1, q2, p2))
    )


def _as_polygon(value) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"must be a list of [x, y] vertices, got {show(value)}")
    vertices = tuple(_as_pair(v, f"vertex {i}") for i, v in enumerate(value))
    n = len(vertices)
    if n < 3:
        raise ValueError(f"needs at least 3 vertices, got {n}")
    if vertices[0] == vertices[-1]:
        raise ValueError("the last vertex repeats the first; the polygon closes itself, leave it out")
    xs, ys = [v[0] for v in vertices], [v[1] for v in vertices]
    extent = max(max(xs) - min(xs), max(ys) - min(ys))
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                if vertices[i] == vertices[j]:
                    raise ValueError(f"vertices {i} and {j} coincide")
                continue
            if _segments_cross(vertices[i], vertices[(i + 1) % n], vertices[j], vertices[(j + 1) % n]):
                raise ValueError(f"edges {i} and {j} cross; the polygon must be simple")
    if abs(polygon_area(vertices)) <= 1e-12 * extent**2 or extent == 0.0:
        raise ValueError(f"has zero area: {show(value)}")
    return vertices


def check_value(spec: Spec, value):
    """``value`` converted to its stored form (float, int, str, tuples); ValueError if invalid."""
    if spec.type == "number":
        x = _as_number(value)
        for op, bound in spec.bounds:
            ok = {">": x > bound, ">=": x >= bound, "<": x < bound, "<=": x <= bound}[op]
            if not ok:
                raise ValueError(f"must be {op} {bound:g}, got {show(value)}")
        return x
    if spec.type == "integer":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"must be an integer, got {show(value)}")
        for op, bound in spec.bounds:
            if not {">=": value >= bound, "<=": value <= bound}[op]:
                raise ValueError(f"must be {op} {bound:g}, got {value}")
        return value
    if spec.type == "text":
        if not isinstance(value, str):
            raise ValueError(f"must be a string, got {show(value)}")
        if spec.choices and value not in spec.choices:
            raise ValueError(f"must be one of {', '.join(map(show, spec.choices))}, got {show(value)}")
        if spec.pattern and not re.match(spec.pattern, value):
            raise ValueError(
                f"must be letters, digits, '_', '.' or '-' (not starting with '_', '.' or '-'), got {show(value)}"
            )
        return value
    if spec.type == "boolean":
        if not isinstance(value, bool):
            raise ValueError(f"must be true or false, got {show(value)}")
        return value
    if spec.type == "names":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ValueError(f"must be a list of names, got {show(value)}")
        if len(set(value)) != len(value):
            raise ValueError(f"lists a name twice: {show(value)}")
        return tuple(value)
    if spec.type == "point":
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise ValueError(f"must be a pair of numbers [x, y], got {show(value)}")
        return (_as_number(value[0]), _as_number(value[1]))
    if spec.type == "polygon":
        return _as_polygon(value)
    raise AssertionError(f"check_value does not handle {spec.type!r}")


# ---------------------------------------------------------------------------------------
# The tables of a study file
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class Record:
    """Base of every table: declared fields are checked and converted on construction.

    Subclasses add cross-field rules in :meth:`check`, raising ``StudyError(field, problem)``
    with ``field`` relative to the table.
    """

    def __post_init__(self):
        for field_name, spec in specs(type(self)).items():
            value = getattr(self, field_name)
            if value is None and field_default(type(self), field_name) is None:
                continue
            try:
                if spec.type == "table":
                    if not isinstance(value, spec.of):
                        raise ValueError(f"must be a {spec.of.__name__}, got {show(value)}")
                elif spec.type == "tables":
                    value = self._check_entries(field_name, spec, tuple(value))
                else:
                    value = check_value(spec, value)
            except ValueError as error:
                if isinstance(error, StudyError):
                    raise
                raise StudyError(field_name, str(error)) from None
            object.__setattr__(self, field_name, value)
        self.check()

    @staticmethod
    def _check_entries(field_name: str, spec: Spec, entries: tuple) -> tuple:
        allowed = tuple(spec.variants.values()) or (spec.of,)
        for i, entry in enumerate(entries):
            if not isinstance(entry, allowed):
                raise StudyError(f"{field_name}[{i}]", f"must be a table, got {show(entry)}")
        if len(entries) < spec.min_items:
            raise StudyError(field_name, f"needs at least {spec.min_items} [[{field_name}]] entry, got {len(entries)}")
        seen: dict[str, int] = {}
        for i, entry in enumerate(entries):
            if entry.name in seen:
                also = f"{field_name}[{seen[entry.name]}]"
                raise StudyError(f"{field_name}[{i}].name", f"duplicate name {show(entry.name)} (also {also})")
            seen[entry.name] = i
        return entries

    def check(self) -> None:
        """Cross-field rules of this table (none by default)."""


@dataclass(frozen=True, kw_only=True)
class StudyInfo(Record):
    """What the study is: its name (the default output folder) and a description."""

    name: str = name_field("name of the study; the default output folder is `./<name>`")
    description: str = text("free text: what the study reproduces and why", default="")


@dataclass(frozen=True, kw_only=True)
class Geometry(Record):
    """The domain and its particle cloud: a polygon filled with particles at spacing h."""

    polygon_m: tuple = polygon("m", "outline of the domain, [[x, y], ...], either orientation, not closed")
    spacing_m: float = number("m", "particle spacing h of the lattice clipped to the polygon", gt=0.0)
    jitter: float = number(
        "1", "random offset of interior particles, as a fraction of h", default=0.0, ge=0.0, lt=0.5
    )
    seed: int = integer("seed of the random jitter", default=0, ge=0)


@dataclass(frozen=True, kw_only=True)
class MaterialBase(Record):
    """Fields shared by every material model."""

    model: ClassVar[str]
    name: str = name_field("name of the material")
    density_kg_m3: float = number("kg/m^3", "mass density rho", gt=0.0)
    youngs_modulus_pa: float = number("Pa", "Young's modulus E", gt=0.0)
    poisson_ratio: float = number("1", "Poisson's ratio nu", ge=0.0, lt=0.5)
    region_m: tuple | None = polygon(
        "m", "polygon of the particles that get this material; default: the whole domain; "
        "later materials override earlier ones", default=None
    )


@dataclass(frozen=True, kw_only=True)
class ElasticMaterial(MaterialBase):
    """Linear elastic, plane strain."""

    model: ClassVar[str] = "elastic"


@dataclass(frozen=True, kw_only=True)
class StrengthMixin(Record):
    """Shear strength (c, phi, psi) of a perfectly plastic material."""

    cohesion_pa: float = number("Pa", "cohesion c", ge=0.0)
    friction_deg: float = number("deg", "friction angle phi", ge=0.0, lt=90.0)
    dilation_deg: float = number("deg", "dilation angle psi (<= phi); 0: no plastic volume change", default=0.0, ge=0.0)

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
    """Mohr-Coulomb, perfectly plastic, plane strain (return map in principal stresses)."""

    model: ClassVar[str] = "mohr_coulomb"


MATERIAL_MODELS: dict[str, type[MaterialBase]] = {
    "elastic": ElasticMaterial,
    "drucker_prager": DruckerPragerMaterial,
    "mohr_coulomb": MohrCoulombMaterial,
}


@dataclass(frozen=True, kw_only=True)
class Loads(Record):
    """Body forces applied from the start of the first stage."""

    gravity_m_s2: tuple = point("m/s^2", "gravitational acceleration [gx, gy]", default=(0.0, -9.81))


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
    vx_m_s: float | None = number("m/s", "prescribed x velocity; default: free", default=None)
    vy_m_s: float | None = number("m/s", "prescribed y velocity; default: free", default=None)

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
        "s", "fixed time step instead of cfl; refused if above the critical step", default=None, gt=0.0
    )
    stabilisation_beta: float = number(
        "1", "rank-deficiency stabilisation factor beta; 0 switches it off", default=0.1, ge=0.0
    )
    alpha: float = number(
        "1", "alpha-shape factor: triangles with circumradius > alpha h are dropped", default=1.5, ge=1.0, le=3.0
    )
    remesh_min_angle_deg: float = number(
        "deg", "rebuild the mesh when its smallest angle falls below this (adapted after each rebuild, "
        "never below 5)", default=20.0, gt=0.0, lt=60.0,
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


@dataclass(frozen=True, kw_only=True)
class StrengthReductionStage(StageBase):
    """Strength reduction: one undamped run per SRF F from the previous stage's stresses, with
    c / F and tan(phi) / F; the FOS is the knee of the SRF-displacement curve (last stage only)."""

    kind: ClassVar[str] = "strength_reduction"
    duration_field: ClassVar[str] = "duration_s"
    duration_s: float = number("s", "simulated time of each SRF run (several response times of the slope)", gt=0.0)
    srf_min: float = number("1", "first SRF of the sweep; below 1 tests whether the slope stands as built", gt=0.0)
    srf_max: float = number("1", "last SRF of the sweep", gt=0.0)
    srf_step: float = number("1", "SRF step of the first sweep (refined around the knee afterwards)", gt=0.0)
    fos_tolerance: float = number(
        "1", "refine until the FOS bracket is at most this wide", default=0.01, gt=0.0
    )
    max_runs: int = integer("never make more SRF runs than this", default=40, ge=3, le=1000)
    failure_displacement_m: float | None = number(
        "m", "a run whose largest displacement exceeds this has failed (and stops there when early_stop "
        "is on); default: 10% of the height of geometry.polygon_m", default=None, gt=0.0,
    )
    displacement_floor_m: float | None = number(
        "m", "displacements below this count as this in the log-scale curve (no mechanism); "
        "default: failure_displacement_m / 1000", default=None, gt=0.0,
    )
    rest_window_s: float = number(
        "s", "at rest: the largest displacement grew by less than rest_growth of itself over the last "
        "window, and by less than over the window before", default=1.0, gt=0.0,
    )
    rest_growth: float = number("1", "see rest_window_s", default=0.01, gt=0.0, lt=1.0)
    early_stop: bool = boolean("end a run once it is at rest or past failure_displacement_m", default=True)

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
        if 2 * self.rest_window_s > self.duration_s and self.early_stop:
            raise StudyError("rest_window_s", f"must be <= duration_s / 2 = {self.duration_s / 2:g}, got {self.rest_window_s:g}")
        if (
            self.failure_displacement_m is not None
            and self.displacement_floor_m is not None
            and self.displacement_floor_m >= self.failure_displacement_m
        ):
            raise StudyError("displacement_floor_m", "must be < failure_displacement_m")


STAGE_KINDS: dict[str, type[StageBase]] = {
    "dynamic": DynamicStage,
    "relaxation": RelaxationStage,
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
        "`<stage>.pvd`); SRF runs are not snapshotted (`python -m workflows.vtk_export OUT` gives their "
        "final states); default: none", default=None, gt=0.0,
    )


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
    boundary: tuple = tables(Boundary, "prescribed velocities (supports), applied in order")
    walls: tuple = tables(Wall, "rigid walls (segments with friction); none: no contact work at all")
    solver: Solver = table(Solver, required=False)
    stages: tuple = tables(
        STAGE_KINDS, "what to run, in order; each stage continues from the state the previous one left",
        key="kind", key_doc="what the stage does", min_items=1,
    )
    monitors: tuple = tables(Monitor, "points recorded during every stage")
    metrics: Metrics | None = _declare(Spec("table", doc=_first_line(Metrics.__doc__), of=Metrics), default=None)
    output: Output = table(Output, required=False)
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
        if self.metrics is not None and self.strength_reduction is not None:
            raise StudyError("metrics", "collapse metrics do not apply to a strength_reduction study")
        known = {b.name for b in self.boundary}
        for i, stage in enumerate(self.stages):
            for name in stage.boundary or ():
                if name not in known:
                    raise StudyError(f"stages[{i}].boundary", f"no [[boundary]] named {name!r} (known: {sorted(known)})")
        for i, monitor in enumerate(self.monitors):
            if not point_in_polygon((monitor.x_m, monitor.y_m), self.geometry.polygon_m):
                raise StudyError(
                    f"monitors[{i}]", f"point ({monitor.x_m:g}, {monitor.y_m:g}) lies outside geometry.polygon_m"
                )


def point_in_polygon(xy, vertices) -> bool:
    """True when ``xy`` is inside the polygon or on its boundary (relative tolerance 1e-9)."""
    x, y = xy
    xs, ys = [v[0] for v in vertices], [v[1] for v in vertices]
    tol = 1e-9 * max(max(xs) - min(xs), max(ys) - min(ys))
    n = len(vertices)
    inside = False
    for i in range(n):
        (x1, y1), (x2, y2) = vertices[i], vertices[(i + 1) % n]
        dx, dy = x2 - x1, y2 - y1
        t = min(1.0, max(0.0, ((x - x1) * dx + (y - y1) * dy) / (dx * dx + dy * dy)))
        if math.hypot(x - (x1 + t * dx), y - (y1 + t * dy)) <= tol:
            return True
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * dx / dy:
            inside = not inside
    return inside


# ---------------------------------------------------------------------------------------
# Reading a study file
# ---------------------------------------------------------------------------------------


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path and not key.startswith("[") else f"{path}{key}"


def _unknown(path: str, key: str, known) -> StudyError:
    hint = difflib.get_close_matches(key, list(known), n=1)
    problem = f"unknown field (did you mean {hint[0]!r}?)" if hint else f"unknown field (known: {', '.join(known)})"
    return StudyError(_join(path, key), problem)


def _build(cls, raw, path: str):
    """An instance of the table dataclass ``cls`` from the TOML table ``raw`` at ``path``."""
    if not isinstance(raw, dict):
        raise StudyError(path, f"must be a table, got {show(raw)}")
    declared = specs(cls)
    for key in raw:
        if key not in declared:
            raise _unknown(path, key, declared)
    values = {}
    for key, spec in declared.items():
        if key not in raw:
            if field_default(cls, key) is REQUIRED:
                kind = {"table": f" (a [{key}] table)", "tables": f" (at least one [[{key}]] table)"}.get(spec.type, "")
                raise StudyError(_join(path, key), f"required field missing{kind}")
            continue
        value = raw[key]
        if spec.type == "table":
            value = _build(spec.of, value, _join(path, key))
        elif spec.type == "tables":
            value = _build_entries(spec, value, _join(path, key))
        values[key] = value
    try:
        return cls(**values)
    except StudyError as error:
        raise StudyError(_join(path, error.field), error.problem) from None


def _build_entries(spec: Spec, raw, path: str) -> tuple:
    if not isinstance(raw, list) or not all(isinstance(entry, dict) for entry in raw):
        raise StudyError(path, f"must be an array of tables ([[{path}]]), got {show(raw)}")
    entries = []
    for i, entry in enumerate(raw):
        where = f"{path}[{i}]"
        cls = spec.of
        if spec.key is not None:
            if spec.key not in entry:
                raise StudyError(f"{where}.{spec.key}", "required field missing")
            kind = entry[spec.key]
            if kind not in spec.variants:
                choices = ", ".join(map(show, spec.variants))
                raise StudyError(f"{where}.{spec.key}", f"must be one of {choices}, got {show(kind)}")
            cls = spec.variants[kind]
            entry = {k: v for k, v in entry.items() if k != spec.key}
        entries.append(_build(cls, entry, where))
    return tuple(entries)


_TOML_POSITION = re.compile(r"^(?P<problem>.*?)\s*\(at line (?P<line>\d+), column (?P<column>\d+)\)$")


def parse_study(toml_text: str) -> Study:
    """The :class:`Study` written in ``toml_text``; :class:`StudyError` if it is not valid."""
    try:
        raw = tomllib.loads(toml_text)
    except tomllib.TOMLDecodeError as error:
        match = _TOML_POSITION.match(str(error))
        if match:
            raise StudyError(f"line {match['line']}, column {match['column']}", match["problem"]) from None
        raise StudyError("toml", str(error)) from None
    study = _build(Study, raw, "")
    return dataclasses.replace(study, source_text=toml_text)


def load_study(path: str | Path) -> Study:
    """The study in the TOML file ``path`` (OSError if unreadable, StudyError if invalid)."""
    return parse_study(Path(path).read_text(encoding="utf-8"))


if __name__ == "__main__":
    from workflows.schema_docs import main

    main()
