"""Fields in the units engineers write: any field in Pa (``<name>_pa``) may be given in kPa
(``<name>_kpa``) or MPa (``<name>_mpa``) instead, and a material's densities by its unit weights
(``unit_weight_kn_m3``, ``saturated_unit_weight_kn_m3``), with the gravity of ``[loads]``:

    rho = 1000 gamma / |g|        (gamma in kN m-3, g = loads.gravity_m_s2 in m s-2)

The field's name says the unit: nothing is guessed from the size of a number.  The study is
built in SI units (Pa, kg m-3), as the result files are written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from workflows.fields import NUMBER, POINT, Spec, StudyError, check_value, show

PRESSURE_SUFFIXES = {"_kpa": 1e3, "_mpa": 1e6}
"""Name ending of a pressure field in kPa or MPa, and its value in Pa per unit."""

UNIT_WEIGHTS = {"unit_weight_kn_m3": "density_kg_m3", "saturated_unit_weight_kn_m3": "saturated_density_kg_m3"}
"""A material's unit weight field (kN m-3) and the density field (kg m-3) it stands for."""

DEFAULT_GRAVITY_M_S2 = (0.0, -9.81)  # workflows.loads.Loads.gravity_m_s2's default

ANY_NUMBER, ANY_POINT = Spec(NUMBER), Spec(POINT)
"""A value given in other units is checked as a number (a point) of the study is, before it is
converted: finite and not too large (an integer of 400 digits times 1e3 would overflow)."""


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _is_number(value) -> bool:
    """A finite TOML number (an integer too large for a float is not one: its own check names it)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _checked(spec: Spec, value, field: str):
    """``value`` as the study's ``spec`` checks it (a float, or a pair of them); StudyError on ``field``."""
    try:
        return check_value(spec, value)
    except ValueError as error:
        raise StudyError(field, str(error)) from None


def pressure_field(key: str, declared: dict) -> tuple[str, float] | None:
    """(the Pa field, Pa per unit) that ``key`` gives in kPa or MPa, if ``declared`` has it."""
    for suffix, factor in PRESSURE_SUFFIXES.items():
        if key.endswith(suffix):
            canonical = key[: -len(suffix)] + "_pa"
            spec = declared.get(canonical)
            if spec is not None and spec.kind is NUMBER and spec.unit == "Pa":
                return canonical, factor
    return None


def spellings(field: str) -> list[str]:
    """Every name of the quantity ``field`` names, the SI one first: ``cohesion_pa``, ``cohesion_kpa``,
    ``cohesion_mpa``; ``density_kg_m3``, ``unit_weight_kn_m3`` (``[field]`` for any other field)."""
    for suffix in ("_pa", *PRESSURE_SUFFIXES):
        if field.endswith(suffix):
            stem = field[: -len(suffix)]
            return [stem + "_pa", *(stem + other for other in PRESSURE_SUFFIXES)]
    for weight, density in UNIT_WEIGHTS.items():
        if field in (weight, density):
            return [density, weight]
    return [field]


def other_names(field: str) -> list[str]:
    """The names of the quantity ``field`` names in the other units (module doc)."""
    return [name for name in spellings(field) if name != field]


def gravity_magnitude_m_s2(raw: dict) -> float | None:
    """|g| of the study dict ``raw`` (``loads.gravity_m_s2``, or its default); None where it is not a
    pair of numbers (its own check names it)."""
    loads = raw.get("loads") if isinstance(raw.get("loads"), dict) else {}
    gravity = loads.get("gravity_m_s2", DEFAULT_GRAVITY_M_S2)
    if isinstance(gravity, (list, tuple)) and len(gravity) == 2 and all(_is_number(v) for v in gravity):
        return math.hypot(*gravity)
    return None


@dataclass(frozen=True)
class Units:
    """A field named in other units than its declaration's (module doc): the declared field, and how
    many of its SI units one unit of the name is."""

    si_field: str
    si_per_unit: float  # NaN for a unit weight without a valid gravity
    unit: str  # UDUNITS: "kPa", "MPa", "kN m-3"


def units_of(key: str, declared: dict, raw: dict) -> Units | None:
    """How ``key`` names a field of a table with the ``declared`` fields in other units, with the
    gravity of the study dict ``raw`` for a unit weight; None for a declared field or another name."""
    if key in declared:
        return None
    pressure = pressure_field(key, declared)
    if pressure is not None:
        return Units(pressure[0], pressure[1], "kPa" if key.endswith("_kpa") else "MPa")
    density = UNIT_WEIGHTS.get(key)
    if density is not None and density in declared:
        g_m_s2 = gravity_magnitude_m_s2(raw)
        return Units(density, 1000.0 / g_m_s2 if g_m_s2 and math.isfinite(g_m_s2) else math.nan, "kN m-3")
    return None


def si_value(node: dict, field: str, declared: dict, raw: dict) -> float | None:
    """The value of the quantity ``field`` names, in SI units, from whichever of its spellings the table
    ``node`` gives (None: none, or not a number)."""
    for name in spellings(field):
        value = node.get(name)
        if not _is_number(value):
            continue
        units = units_of(name, declared, raw)
        return float(value) * (1.0 if units is None else units.si_per_unit)
    return None


def in_pascals(raw: dict, declared: dict, path: str) -> tuple[dict, dict]:
    """The table ``raw`` with its kPa and MPa fields given in Pa, and {Pa field: the name used}."""
    table: dict = {}
    given_as: dict[str, str] = {}
    for key, value in raw.items():
        alias = None if key in declared else pressure_field(key, declared)
        if alias is None:
            table[key] = value
            continue
        canonical, factor = alias
        other = canonical if canonical in raw else given_as.get(canonical)
        if other is not None:
            raise StudyError(_join(path, key), f"give {key} or {other}, not both")
        table[canonical], given_as[canonical] = _checked(ANY_NUMBER, value, _join(path, key)) * factor, key
    return table, given_as


def with_densities(raw: dict) -> tuple[dict, dict]:
    """The study dict ``raw`` with its materials' unit weights given as densities (module doc),
    and {density field's path: the unit weight's path} for the messages."""
    materials = raw.get("materials")
    if not isinstance(materials, list) or not any(
        isinstance(m, dict) and any(key in m for key in UNIT_WEIGHTS) for m in materials
    ):
        return raw, {}
    loads = raw.get("loads") if isinstance(raw.get("loads"), dict) else {}
    gravity = _checked(ANY_POINT, loads.get("gravity_m_s2", DEFAULT_GRAVITY_M_S2), "loads.gravity_m_s2")
    g_m_s2 = math.hypot(*gravity)
    converted, given_as = [], {}
    for i, material in enumerate(materials):
        material = dict(material) if isinstance(material, dict) else material
        for weight_key, density_key in UNIT_WEIGHTS.items():
            if not isinstance(material, dict) or weight_key not in material:
                continue
            field, weight = f"materials[{i}].{weight_key}", material.pop(weight_key)
            if density_key in material:
                raise StudyError(field, f"give {weight_key} or {density_key}, not both")
            if not _checked(ANY_NUMBER, weight, field) > 0.0:
                raise StudyError(field, f"must be a number > 0, got {show(weight)}")
            if not g_m_s2 > 0.0:
                raise StudyError(field, f"a unit weight needs gravity, and loads.gravity_m_s2 is "
                                 f"{show(list(gravity))}: give {density_key} instead")
            material[density_key] = 1000.0 * weight / g_m_s2
            given_as[f"materials[{i}].{density_key}"] = field
        converted.append(material)
    return dict(raw, materials=converted), given_as
