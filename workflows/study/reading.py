"""Reading a study file: TOML text to a checked :class:`~workflows.study.tables.Study`.

A study file is data only: it is read with :mod:`tomllib` and never executes code.  Unknown
fields, missing required ones and values a declaration refuses raise :class:`StudyError` with
the path of the field (``stages[1].duration_s``), before anything runs.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
import tomllib
from pathlib import Path

from workflows.study.fields import REQUIRED, Spec, StudyError, field_default, show, specs
from workflows.study.tables import Study


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
            if not isinstance(kind, str) or kind not in spec.variants:
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
    """The study in the TOML file ``path`` (OSError if unreadable, StudyError if invalid)."""
    return parse_study(decode_study_bytes(Path(path).read_bytes()))

