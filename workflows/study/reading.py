"""Reading a study file: TOML text to a checked :class:`~workflows.study.tables.Study`.

A study file is data only: it is read with :mod:`tomllib` and never executes code.  Unknown
fields, missing required ones and values a declaration refuses raise :class:`StudyError` with
the path of the field (``stages[1].duration_s``), before anything runs.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import itertools
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from workflows import engineering_units
from workflows.fields import REQUIRED, Spec, StudyError, check_value, field_default, show, specs
from workflows.study import line_files, section_form, slope_form
from workflows.study.geometry import SectionForm, SlopeForm
from workflows.study.tables import Study
from workflows.study.toml_text import to_toml


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
    written = raw
    raw, given_as = engineering_units.in_pascals(written, declared, path)
    for key in raw:
        if key not in declared:
            raise _unknown(path, key, declared)
    values = {}
    for key, spec in declared.items():
        if key not in raw:
            if field_default(cls, key) is REQUIRED:
                raise StudyError(_join(path, key), f"required field missing{spec.kind.missing(key)}")
            continue
        values[key] = spec.kind.visit(_Building, spec, raw[key], _join(path, key))
    try:
        return cls(**values)
    except StudyError as error:
        if error.field in given_as:  # a value given in kPa or MPa: name it as written
            alias = given_as[error.field]
            raise StudyError(_join(path, alias), f"{error.problem} (in Pa; {alias} = {show(written[alias])})") \
                from None
        raise StudyError(_join(path, error.field), error.problem) from None


class _Building:
    """What the reader makes of a field as the file gives it, by its kind (``FieldKind.visit``): a value
    as it is (its table converts and checks it), a nested table or an array of tables built."""

    @staticmethod
    def value(spec: Spec, raw, path: str):
        return raw

    @staticmethod
    def table(spec: Spec, raw, path: str):
        return _build(spec.of, raw, path)

    @staticmethod
    def tables(spec: Spec, raw, path: str):
        return _build_entries(spec, raw, path)


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
            if not isinstance(kind, str) or kind not in spec.variants:
                choices = ", ".join(map(show, spec.variants))
                raise StudyError(f"{where}.{spec.key}", f"must be one of {choices}, got {show(kind)}")
            cls = spec.variants[kind]
            entry = {k: v for k, v in entry.items() if k != spec.key}
        entries.append(_build(cls, entry, where))
    return tuple(entries)


_TOML_POSITION = re.compile(r"^(?P<problem>.*?)\s*\(at line (?P<line>\d+), column (?P<column>\d+)\)$")


def _loads(toml_text: str) -> dict:
    try:
        return tomllib.loads(toml_text)
    except tomllib.TOMLDecodeError as error:
        match = _TOML_POSITION.match(str(error))
        if match:
            raise StudyError(f"line {match['line']}, column {match['column']}", match["problem"]) from None
        raise StudyError("toml", str(error)) from None


def _build_study(raw: dict) -> Study:
    """The Study of a study dict, a slope form (``[geometry.slope]``) or a section drawn as lines
    (``[geometry.section]``) expanded first."""
    weights: dict = {}
    if isinstance(raw, dict):
        raw, weights = engineering_units.with_densities(raw)
    geometry = raw.get("geometry") if isinstance(raw, dict) else None
    if isinstance(geometry, dict) and "slope" in geometry:
        raw = slope_form.expand(raw, _build(SlopeForm, geometry["slope"], "geometry.slope"))
    if isinstance(geometry, dict) and "section" in geometry:
        raw = section_form.expand(raw, _build(SectionForm, geometry["section"], "geometry.section"))
    try:
        return _build(Study, raw, "")
    except StudyError as error:
        if error.field in weights:  # a density given as a unit weight: name it as written
            raise StudyError(weights[error.field], f"{error.problem} (as a density in kg m-3)") from None
        raise


def parse_study(toml_text: str) -> Study:
    """The :class:`Study` written in ``toml_text``; :class:`StudyError` if it is not valid (a
    sweep's cases are checked too, :func:`sweep_cases`)."""
    study = dataclasses.replace(_build_study(_loads(toml_text)), source_text=toml_text)
    if study.sweep is not None:
        sweep_cases(study)
    return study


@dataclass(frozen=True)
class SweepCase:
    """One case of a sweep: its id (a folder name), the values of the axes, its own study."""

    case_id: str
    position: tuple[int, ...]  # index along each axis (grid), or (i,) the i-th case (zip)
    values: dict  # axis label -> the value of this case
    study: Study  # no sweep; source_text its own TOML text


def axis_labels(sweep) -> list[str]:
    """A short name per axis: the field's name, with the entry or table before it where two axes
    would share one (``soil_cohesion_pa``)."""
    leaves = [axis.path.split(".")[-1] for axis in sweep.axes]
    return [leaf if leaves.count(leaf) == 1 else "_".join(axis.path.split(".")[-2:])
            for leaf, axis in zip(leaves, sweep.axes)]


@dataclass(frozen=True)
class FieldAt:
    """A number or value field of a study dict, found by its path (:func:`resolve_field`)."""

    node: dict  # the table that holds it
    key: str  # its name as the path gives it: a declared field, or one in other units (``cohesion_kpa``)
    spec: Spec  # its declaration, in the unit of ``key`` (bounds too)
    table: type  # the class of the table that holds it
    where: str  # that table in messages: ``materials[0]``, ``stages[1]``, ``loads``


def resolve_field(raw: dict, path: str) -> FieldAt:
    """The field at a sweep ``path`` in the study dict ``raw`` (a missing optional table is created); a
    field named in other units than its declaration's (``materials.soil.cohesion_kpa``,
    ``unit_weight_kn_m3``: ``workflows.engineering_units``) is found with its declaration in those
    units.  StudyError (field ``path``) otherwise."""
    parts = path.split(".")
    cls: type = Study
    node, i, where = raw, 0, ""
    while i < len(parts):
        part = parts[i]
        declared = specs(cls)
        units = engineering_units.units_of(part, declared, raw) if i == len(parts) - 1 else None
        if units is not None:
            si_spec = declared[units.si_field]
            scaled = {name: getattr(si_spec, name) / units.si_per_unit for name in ("gt", "ge", "lt", "le")
                      if getattr(si_spec, name) is not None}
            doc = f"{si_spec.doc} ({units.si_field} in {units.unit})"
            return FieldAt(node, part, dataclasses.replace(si_spec, unit=units.unit, doc=doc, **scaled), cls, where)
        if part not in declared or (cls is Study and part in ("sweep", "probabilistic")):
            raise _unknown(".".join(parts[:i]), part, [k for k in declared if k not in ("sweep", "probabilistic")])
        spec = declared[part]
        step = spec.kind.visit(_PathStep, spec, path, parts, i, node, where)
        if step is None:
            if i != len(parts) - 1:
                raise StudyError(path, f"{part} is a value, not a table")
            return FieldAt(node, part, spec, cls, where)
        node, cls, i, where = step
    raise StudyError(path, "is empty")


class _PathStep:
    """One step of :func:`resolve_field` down a sweep ``path`` at its part ``parts[i]``, by the field's kind
    (``FieldKind.visit``): into a nested table (one part) or an entry of an array of tables (two parts:
    the array and the entry's name), as (the table's dict, its class, the next part, where); None at a value."""

    @staticmethod
    def value(spec: Spec, path: str, parts: list[str], i: int, node: dict, where: str):
        return None

    @staticmethod
    def table(spec: Spec, path: str, parts: list[str], i: int, node: dict, where: str):
        part = parts[i]
        if i == len(parts) - 1:
            raise StudyError(path, "is a table: name one of its fields")
        return node.setdefault(part, {}), spec.of, i + 1, _join(where, part)

    @staticmethod
    def tables(spec: Spec, path: str, parts: list[str], i: int, node: dict, where: str):
        part = parts[i]
        if i + 2 >= len(parts):
            raise StudyError(path, f"name an entry and a field: {part}.<{spec.unique}>.<field>")
        entries = node.get(part, [])
        names = [entry.get(spec.unique) for entry in entries if isinstance(entry, dict)]
        if parts[i + 1] not in names:
            known = (f"known: {', '.join(map(str, names))}" if names else
                     f"the study file gives no [[{part}]]; those a [geometry.slope] makes cannot be swept")
            raise StudyError(path, f"no [[{part}]] with {spec.unique} {parts[i + 1]!r} ({known})")
        position = [k for k, entry in enumerate(entries) if isinstance(entry, dict)][names.index(parts[i + 1])]
        entry = entries[position]
        cls = spec.variants.get(entry.get(spec.key), spec.of) if spec.key else spec.of
        if not isinstance(cls, type):
            raise StudyError(path, f"the entry's {spec.key} is not valid")
        return entry, cls, i + 2, f"{_join(where, part)}[{position}]"


def resolve_sweep_path(raw: dict, path: str) -> tuple[dict, str, Spec]:
    """(the dict that holds the field, its key, its declaration in the key's unit) of a sweep ``path`` in
    the study dict ``raw`` (:func:`resolve_field`)."""
    found = resolve_field(raw, path)
    return found.node, found.key, found.spec


def set_field(node: dict, key: str, value) -> None:
    """``value`` as the field ``key`` of the table ``node``, the same quantity given in other units
    removed (``cohesion_pa`` set, ``cohesion_kpa`` gone: engineering_units)."""
    node[key] = value
    for other in engineering_units.other_names(key):
        node.pop(other, None)


def sweep_cases(study: Study) -> list[SweepCase]:
    """The cases of ``study.sweep`` in order (grid: the last axis varies fastest), each its own
    checked study.  StudyError naming the axis, value or case that fails."""
    sweep = study.sweep
    raw = _loads(study.source_text)
    raw.pop("sweep", None)
    labels = axis_labels(sweep)
    axes_values = []
    for a, axis in enumerate(sweep.axes):
        try:
            _, _, spec = resolve_sweep_path(copy.deepcopy(raw), axis.path)
        except StudyError as error:
            raise StudyError(f"sweep.axes[{a}].path", str(error)) from None
        checked = []
        for j, value in enumerate(axis.points):
            try:
                checked.append((value, check_value(spec, value)))
            except ValueError as error:
                raise StudyError(f"sweep.axes[{a}].values[{j}]", f"{axis.path}: {error}") from None
        axes_values.append(checked)
    positions: list[tuple[int, ...]]
    if sweep.combination == "zip":
        positions = [(i,) for i in range(len(axes_values[0]))]
        combos = [tuple(values[i] for values in axes_values) for i in range(len(axes_values[0]))]
    else:
        positions = list(itertools.product(*(range(len(values)) for values in axes_values)))
        combos = [tuple(values[i] for values, i in zip(axes_values, position)) for position in positions]
    cases: dict[str, SweepCase] = {}
    for position, combo in zip(positions, combos):
        case_raw = copy.deepcopy(raw)
        for axis, (value, _) in zip(sweep.axes, combo):
            node, key, _ = resolve_sweep_path(case_raw, axis.path)
            set_field(node, key, list(value) if isinstance(value, tuple) else value)
        values = {label: stored for label, (_, stored) in zip(labels, combo)}
        case_id = "__".join(f"{label}={_case_value(v)}" for label, v in values.items())
        if case_id in cases:
            raise StudyError("sweep", f"two cases would share the folder {case_id}: make the values differ more")
        text = to_toml(case_raw, header=f"case {case_id} of the sweep of study {study.name}")
        try:
            case_study = dataclasses.replace(_build_study(case_raw), source_text=text)
        except StudyError as error:
            raise case_error(case_id, error) from None
        cases[case_id] = SweepCase(case_id, position, values, case_study)
    return list(cases.values())


def case_error(case_id: str, error: StudyError) -> StudyError:
    """The StudyError of one case of a sweep (``case_id`` as :func:`sweep_cases` makes it), the case
    named before the field it names."""
    return StudyError("sweep", f"the case {case_id.replace('__', ', ')}: {error}")


def _case_value(value) -> str:
    """A value as it appears in a case id (a folder name)."""
    if isinstance(value, float):
        text = f"{value:.6g}" if float(f"{value:.6g}") == value else repr(value)
    elif isinstance(value, tuple):
        text = "_".join(_case_value(v) for v in value)
    else:
        text = str(value)
    return re.sub(r"[^A-Za-z0-9_.+-]", "-", text)


def decode_study_bytes(data: bytes) -> str:
    """The text of a study file: UTF-8 as TOML requires (a leading byte-order mark is dropped);
    StudyError naming the first offending byte otherwise, with a hint for UTF-16 files."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        head = data[:64]
        utf16 = data[:2] in (b"\xff\xfe", b"\xfe\xff") or (
            len(head) >= 8 and max(head[0::2].count(0), head[1::2].count(0)) >= 0.4 * len(head)
        )
        hint = "; it looks like UTF-16: save it as UTF-8" if utf16 else ""
        raise StudyError(
            "", f"not a UTF-8 text file (TOML files are UTF-8): byte 0x{data[error.start]:02x} at position "
            f"{error.start}{hint}"
        ) from None


def load_study(path: str | Path) -> Study:
    """The study in the TOML file ``path`` (OSError if unreadable, StudyError if invalid).  Lines
    given as file names (:mod:`workflows.study.line_files`) are read in, and the study's text is
    then the file with those lines written out."""
    path = Path(path)
    toml_text = decode_study_bytes(path.read_bytes())
    raw = _loads(toml_text)
    read = line_files.read_line_files(raw, path.parent)
    if read:
        toml_text = to_toml(raw, header=f"{path.name} with the lines of {', '.join(read)} written out")
    return parse_study(toml_text)

