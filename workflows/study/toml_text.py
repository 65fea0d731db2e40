"""Writing a study back as TOML text: the study file of each case of a sweep.

:func:`to_toml` writes the nested dict that :mod:`tomllib` reads from a study file (tables,
arrays of tables, strings, booleans, numbers, lists): ``tomllib.loads(to_toml(d)) == d`` for
every such dict (``tests/test_study.py``).  Floats keep their full precision (``repr``).
"""

from __future__ import annotations

import json
import math


def toml_value(value) -> str:
    """One TOML value: a string, boolean, integer, float (nan and inf too), list or inline table."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def _key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() and key.isascii() else json.dumps(key)


def _is_table_array(value) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(entry, dict) for entry in value)


def _table_lines(prefix: str, table: dict) -> list[str]:
    """``[prefix]`` with its plain values, then its nested tables and arrays of tables."""
    plain = {k: v for k, v in table.items() if not isinstance(v, dict) and not _is_table_array(v)}
    lines = [f"[{prefix}]"] if prefix else []
    lines += [f"{_key(k)} = {toml_value(v)}" for k, v in plain.items()]
    for key, value in table.items():
        name = f"{prefix}.{_key(key)}" if prefix else _key(key)
        if isinstance(value, dict):
            lines += ["", *_table_lines(name, value)]
        elif _is_table_array(value):
            for entry in value:
                sub = _table_lines(name, entry)
                sub[0] = f"[[{name}]]"
                lines += ["", *sub]
    return lines


def to_toml(data: dict, header: str = "") -> str:
    """TOML text of a study-shaped dict, after the comment lines of ``header``."""
    comment = "".join(f"# {line}\n" for line in header.splitlines())
    return comment + "\n".join(_table_lines("", data)).lstrip("\n") + "\n"
