"""How a study-file field is declared, checked and converted: the kit every table is made of.

Every field is declared once, on the frozen dataclass of its table, with its type, unit,
default, bounds and documentation (``number``, ``integer``, ``text``, ``point``, ``polygon``,
``table``, ``tables`` below).  From that one declaration come the checks (a :class:`Record`
checks its declared fields on construction and raises :class:`StudyError` with a one-line
message ``<field path>: <problem>``), the JSON schema and the study-file reference
(``workflows.study.reference``).  Units are UDUNITS strings ("m", "m s-1", "kg m-3",
"degree"; "1" for a dimensionless number), as in the result files.
"""

from __future__ import annotations

import builtins
import dataclasses
import json
import math
import re
from dataclasses import dataclass
from typing import Any

from spfem_core.geometry import polygon_problem

MAX_NAME_LENGTH = 64
NAME_PATTERN = rf"^[A-Za-z0-9][A-Za-z0-9_.-]{{0,{MAX_NAME_LENGTH - 1}}}$"
"""Names of studies, stages, materials, boundaries and monitors: they become folder,
file and coordinate names, so letters, digits, ``_``, ``.`` and ``-`` only, at most
``MAX_NAME_LENGTH`` of them (a file name and its suffixes stay far below the 255 bytes file
systems allow)."""

REQUIRED = dataclasses.MISSING


class StudyError(ValueError):
    """A study file that cannot be run; ``str()`` is one line ``<field>: <problem>``."""

    def __init__(self, field: str, problem: str):
        self.field = field
        self.problem = " ".join(str(problem).split())
        super().__init__(f"{field}: {self.problem}" if field else self.problem)

    def __reduce__(self):  # crosses to and from dask workers whole (the default would lose the field)
        return StudyError, (self.field, self.problem)


# ---------------------------------------------------------------------------------------
# How a field is declared
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Spec:
    """How one field of a study file is written, checked and documented.

    ``kind`` is one of :data:`FIELD_KINDS` (each with its check and conversion, its JSON schema and
    its name in the reference): ``number`` (a float; an integer is accepted, a boolean is not),
    ``integer``, ``text``, ``boolean``, ``names``, ``point`` ([x, y]), ``polygon`` ([[x, y], ...]),
    ``polyline`` ([[x, y], ...] with x increasing), ``numbers`` (a list of numbers), ``values`` (a
    non-empty list of any TOML values, checked by whoever uses them), ``table`` (one nested table,
    class ``of``) or ``tables`` (an array of tables: ``of`` is a class, or a dict from the value of
    the ``key`` field to a class; entries need unique values of the field ``unique``).
    """

    kind: FieldKind
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
    unique: str = "name"

    @property
    def bounds(self) -> list[tuple[str, float]]:
        """The bounds that apply, as (operator, value) pairs."""
        pairs = [(">", self.gt), (">=", self.ge), ("<", self.lt), ("<=", self.le)]
        return [(op, value) for op, value in pairs if value is not None]

    @property
    def variants(self) -> dict[str, builtins.type]:  # (the field `type` hides the builtin here)
        """For ``tables`` with a ``key``: kind -> dataclass; otherwise {}."""
        return dict(self.of) if isinstance(self.of, dict) else {}


def _declare(spec: Spec, default=REQUIRED, default_factory=REQUIRED):
    return dataclasses.field(default=default, default_factory=default_factory, metadata={"spec": spec})


def number(unit, doc, *, default=REQUIRED, gt=None, ge=None, lt=None, le=None):
    """A finite float field (``unit`` "1" for a dimensionless number)."""
    return _declare(Spec(NUMBER, unit, doc, gt=gt, ge=ge, lt=lt, le=le), default)


def integer(doc, *, default=REQUIRED, ge=None, le=None):
    """An integer field."""
    return _declare(Spec(INTEGER, "1", doc, ge=ge, le=le), default)


def text(doc, *, default=REQUIRED, choices=(), pattern=None):
    """A string field, optionally limited to ``choices`` or a regular expression."""
    return _declare(Spec(TEXT, "", doc, choices=tuple(choices), pattern=pattern), default)


def boolean(doc, *, default=REQUIRED):
    """A true/false field."""
    return _declare(Spec(BOOLEAN, "", doc), default)


def names(doc, *, default=REQUIRED):
    """A list of names (of other entries of the study), e.g. ["base", "left"]."""
    return _declare(Spec(NAMES, "", doc), default)


def name_field(doc):
    """A required name made of letters, digits, ``_``, ``.`` and ``-``."""
    return text(doc, pattern=NAME_PATTERN)


def numbers(unit, doc, *, default=REQUIRED, gt=None, ge=None, lt=None, le=None):
    """A list of finite numbers, each within the bounds, e.g. [5.0, 10.0]."""
    return _declare(Spec(NUMBERS, unit, doc, gt=gt, ge=ge, lt=lt, le=le), default)


def _frozen(value):
    """A TOML list as nested tuples: a table's values are immutable (and a study hashable)."""
    return tuple(_frozen(v) for v in value) if isinstance(value, (list, tuple)) else value


def any_values(doc, *, default=REQUIRED):
    """A non-empty list of TOML values of any type (their meaning is checked where they are used)."""
    return _declare(Spec(VALUES, "", doc), default)


def point(unit, doc, *, default=REQUIRED):
    """A pair of numbers [x, y]."""
    return _declare(Spec(POINT, unit, doc), default)


def polygon(unit, doc, *, default=REQUIRED):
    """A simple polygon [[x, y], ...]: at least 3 vertices, non-zero area, no crossing edges."""
    return _declare(Spec(POLYGON, unit, doc), default)


def polyline(unit, doc, *, default=REQUIRED):
    """A line y(x) [[x, y], ...]: at least 2 points, x strictly increasing."""
    return _declare(Spec(POLYLINE, unit, doc), default)


def table(of: type, *, required: bool = True):
    """A nested table ``[name]`` described by the dataclass ``of`` (its docstring documents it);
    not ``required``: an absent table takes every default of ``of``."""
    spec = Spec(TABLE, doc=_first_line(of.__doc__), of=of)
    return _declare(spec) if required else _declare(spec, default_factory=of)


def optional_table(of: type):
    """A nested table ``[name]`` that is None when absent (what it describes does not happen)."""
    return _declare(Spec(TABLE, doc=_first_line(of.__doc__), of=of), default=None)


def tables(of, doc, *, key=None, key_doc="", min_items=0, unique="name"):
    """An array of tables ``[[name]]``; entries need unique values of the field ``unique``.

    ``of`` is a dataclass, or with ``key`` a dict from the value of that field to the
    dataclass of that kind of entry.
    """
    spec = Spec(TABLES, doc=doc, of=of, key=key, key_doc=key_doc, min_items=min_items, unique=unique)
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
    if isinstance(value, int) and abs(value) > 10**15:
        return f"an integer of {len(str(abs(value))) if value.bit_length() < 14000 else 'thousands of'} digits"
    return repr(value) if isinstance(value, float) else str(value)


MAX_MAGNITUDE = 1e12
"""No number of a study file is larger than this in magnitude (SI units): products of a few of
them stay finite in float64, and nothing physical is near it (steel's E is 2e11 Pa)."""


def _as_number(value, what="must be a number") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = " (a boolean)" if isinstance(value, bool) else ""
        raise ValueError(f"{what}, got {show(value)}{kind}")
    try:
        x = float(value)
    except OverflowError:  # an integer too large for a float
        x = math.inf
    if not math.isfinite(x):
        raise ValueError(f"must be finite, got {show(value)}")
    if abs(x) > MAX_MAGNITUDE:
        raise ValueError(f"must be at most {MAX_MAGNITUDE:g} in magnitude, got {show(value)}")
    return x


def _as_pair(value, what: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"{what} must be a pair of numbers [x, y], got {show(value)}")
    return (_as_number(value[0], f"{what} must be numbers"), _as_number(value[1], f"{what} must be numbers"))


def _as_polygon(value) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"must be a list of [x, y] vertices, got {show(value)}")
    vertices = tuple(_as_pair(v, f"vertex {i}") for i, v in enumerate(value))
    if len(vertices) > 3 and vertices[0] == vertices[-1]:
        raise ValueError("the last vertex repeats the first; the polygon closes itself, leave it out")
    problem = polygon_problem(vertices)
    if problem is not None:
        raise ValueError(problem)
    return vertices


def _as_polyline(value) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"must be a list of [x, y] points, got {show(value)}")
    points = tuple(_as_pair(v, f"point {i}") for i, v in enumerate(value))
    if len(points) < 2:
        raise ValueError(f"needs at least 2 points, got {len(points)}")
    for i in range(1, len(points)):
        if not points[i][0] > points[i - 1][0]:
            raise ValueError(f"x must increase from point to point: point {i} has x = {points[i][0]:g} after "
                             f"{points[i - 1][0]:g}")
    return points


def check_value(spec: Spec, value):
    """``value`` converted to its stored form (float, int, str, tuples); ValueError if invalid
    (its kind's :meth:`FieldKind.parse`)."""
    return spec.kind.parse(spec, value)


PAIR_SCHEMA = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}


class FieldKind:
    """One kind of study-file field (``Spec.kind``): how a value of it is checked and converted
    (:meth:`parse`), what the JSON schema says of it (:meth:`schema`) and how the study-file reference
    names it (``shown``, :meth:`allowed`).  ``workflows.study.reference`` and the study reader ask it."""

    name: str
    shown: str  # its type in the reference
    json_type: str = ""  # a scalar's JSON type

    def __repr__(self) -> str:
        return self.name

    def parse(self, spec: Spec, value):
        """``value`` in its stored form; ValueError naming the problem."""
        raise NotImplementedError

    def convert(self, field_name: str, spec: Spec, value):
        """The value a table stores for its field ``field_name`` (a table's own check: :class:`Record`)."""
        return self.parse(spec, value)

    def schema(self, spec: Spec) -> dict:
        """The JSON schema of a value: its type, bounds, choices and pattern."""
        schema: dict = {"type": self.json_type}
        for op, bound in spec.bounds:
            schema[_BOUND_KEYWORDS[op]] = bound
        if spec.choices:
            schema["enum"] = list(spec.choices)
        if spec.pattern:
            schema["pattern"] = spec.pattern
        return schema

    def allowed(self, spec: Spec) -> str:
        """The reference's "Allowed" column: its choices, its name pattern, or its :meth:`limits`."""
        if spec.choices:
            return ", ".join(f"`{c}`" for c in spec.choices)
        if spec.pattern == NAME_PATTERN:
            return f"letters, digits, `_` `.` `-`, at most {MAX_NAME_LENGTH}"
        return self.limits(spec)

    def limits(self, spec: Spec) -> str:
        """What a value must satisfy: its bounds."""
        return ", ".join(f"{op} {bound:g}" for op, bound in spec.bounds)

    def missing(self, key: str) -> str:
        """What the message of a missing required field adds (a table's kind)."""
        return ""

    def visit(self, visitor, spec: Spec, *args):
        """What ``visitor`` does with a field of this kind: ``visitor.value`` with a value, ``visitor.table``
        with one nested table, ``visitor.tables`` with an array of tables, each called with ``spec`` and
        ``args`` (how the study reader and the reference walk the tables)."""
        return visitor.value(spec, *args)


_BOUND_KEYWORDS = {">": "exclusiveMinimum", ">=": "minimum", "<": "exclusiveMaximum", "<=": "maximum"}


class Number(FieldKind):
    name, shown, json_type = "number", "float", "number"

    def parse(self, spec, value):
        x = _as_number(value)
        for op, bound in spec.bounds:
            ok = {">": x > bound, ">=": x >= bound, "<": x < bound, "<=": x <= bound}[op]
            if not ok:
                raise ValueError(f"must be {op} {bound:g}, got {show(value)}")
        return x


class Numbers(FieldKind):
    name, shown = "numbers", "`[float, ...]`"

    def parse(self, spec, value):
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"must be a list of numbers, got {show(value)}")
        element = dataclasses.replace(spec, kind=NUMBER)
        return tuple(NUMBER.parse(element, v) for v in value)

    def schema(self, spec):
        return {"type": "array", "items": NUMBER.schema(Spec(NUMBER, gt=spec.gt, ge=spec.ge, lt=spec.lt, le=spec.le))}


class Values(FieldKind):
    name, shown = "values", "`[value, ...]`"

    def parse(self, spec, value):
        if not isinstance(value, (list, tuple)) or not value:
            raise ValueError(f"must be a non-empty list of values, got {show(value)}")
        return _frozen(value)

    def schema(self, spec):
        return {"type": "array", "minItems": 1}


class Integer(FieldKind):
    name, shown, json_type = "integer", "int", "integer"

    def parse(self, spec, value):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"must be an integer, got {show(value)}")
        for op, bound in spec.bounds:
            if not {">=": value >= bound, "<=": value <= bound}[op]:
                raise ValueError(f"must be {op} {bound:g}, got {value}")
        return value


class Text(FieldKind):
    name, shown, json_type = "text", "string", "string"

    def parse(self, spec, value):
        if not isinstance(value, str):
            raise ValueError(f"must be a string, got {show(value)}")
        if spec.choices and value not in spec.choices:
            raise ValueError(f"must be one of {', '.join(map(show, spec.choices))}, got {show(value)}")
        if spec.pattern == NAME_PATTERN and len(value) > MAX_NAME_LENGTH:
            raise ValueError(f"must be at most {MAX_NAME_LENGTH} characters, got {len(value)}")
        if spec.pattern and not re.match(spec.pattern, value):
            raise ValueError(
                f"must be letters, digits, '_', '.' or '-' (not starting with '_', '.' or '-'), got {show(value)}"
            )
        return value


class Boolean(FieldKind):
    name, shown, json_type = "boolean", "bool", "boolean"

    def parse(self, spec, value):
        if not isinstance(value, bool):
            raise ValueError(f"must be true or false, got {show(value)}")
        return value


class Names(FieldKind):
    name, shown = "names", "`[name, ...]`"

    def parse(self, spec, value):
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ValueError(f"must be a list of names, got {show(value)}")
        if len(set(value)) != len(value):
            raise ValueError(f"lists a name twice: {show(value)}")
        return tuple(value)

    def schema(self, spec):
        return {"type": "array", "items": {"type": "string", "pattern": NAME_PATTERN}}


class Point(FieldKind):
    name, shown = "point", "`[x, y]`"

    def parse(self, spec, value):
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise ValueError(f"must be a pair of numbers [x, y], got {show(value)}")
        return (_as_number(value[0]), _as_number(value[1]))

    def schema(self, spec):
        return dict(PAIR_SCHEMA)


class Polygon(FieldKind):
    name, shown = "polygon", "`[[x, y], ...]`"

    def parse(self, spec, value):
        return _as_polygon(value)

    def schema(self, spec):
        return {"type": "array", "items": PAIR_SCHEMA, "minItems": 3}

    def limits(self, spec):
        return ">= 3 vertices, simple, area > 0"


class Polyline(FieldKind):
    name, shown = "polyline", "`[[x, y], ...]` or file"

    def parse(self, spec, value):
        return _as_polyline(value)

    def schema(self, spec):
        """Points, or a line file (``workflows.study.line_files``)."""
        return {"anyOf": [{"type": "array", "items": PAIR_SCHEMA, "minItems": 2}, {"type": "string", "minLength": 1}]}

    def limits(self, spec):
        return ">= 2 points, x increasing"


class Table(FieldKind):
    """One nested table ``[name]`` of class ``Spec.of`` (built by the study reader)."""

    name, shown = "table", ""

    def convert(self, field_name, spec, value):
        if not isinstance(value, spec.of):
            raise ValueError(f"must be a {spec.of.__name__}, got {show(value)}")
        return value

    def missing(self, key):
        return f" (a [{key}] table)"

    def visit(self, visitor, spec, *args):
        return visitor.table(spec, *args)


class Tables(FieldKind):
    """An array of tables ``[[name]]`` (built by the study reader)."""

    name, shown = "tables", ""

    def convert(self, field_name, spec, value):
        return Record._check_entries(field_name, spec, tuple(value))

    def missing(self, key):
        return f" (at least one [[{key}]] table)"

    def visit(self, visitor, spec, *args):
        return visitor.tables(spec, *args)


NUMBER, NUMBERS, VALUES, INTEGER, TEXT, BOOLEAN = Number(), Numbers(), Values(), Integer(), Text(), Boolean()
NAMES, POINT, POLYGON, POLYLINE, TABLE, TABLES = Names(), Point(), Polygon(), Polyline(), Table(), Tables()
FIELD_KINDS: dict[str, FieldKind] = {kind.name: kind for kind in (NUMBER, NUMBERS, VALUES, INTEGER, TEXT, BOOLEAN,
                                                                  NAMES, POINT, POLYGON, POLYLINE, TABLE, TABLES)}
"""Every kind of field, by its name."""


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
                value = spec.kind.convert(field_name, spec, value)
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
            key = getattr(entry, spec.unique)
            if key in seen:
                also = f"{field_name}[{seen[key]}]"
                raise StudyError(f"{field_name}[{i}].{spec.unique}", f"duplicate {spec.unique} {show(key)} (also {also})")
            seen[key] = i
        return entries

    def check(self) -> None:
        """Cross-field rules of this table (none by default)."""
