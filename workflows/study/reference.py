"""The study-file reference, generated from the declarations in :mod:`workflows.study.tables`.

    python -m workflows.study.reference > docs/study-file.md     # the reference page
    python -m workflows.study.reference --json-schema            # JSON schema (draft 2020-12)

The test suite fails when ``docs/study-file.md`` differs from :func:`page`.
"""

from __future__ import annotations

import argparse
import json
import sys

from workflows import engineering_units
from workflows.fields import NUMBER, REQUIRED, Spec, field_default, show, specs
from workflows.study.tables import Study

REGENERATE = "python -m workflows.study.reference > docs/study-file.md"

_BOUND_KEYWORDS = {">": "exclusiveMinimum", ">=": "minimum", "<": "exclusiveMaximum", "<=": "maximum"}


# ---------------------------------------------------------------------------------------
# JSON schema
# ---------------------------------------------------------------------------------------


def _describe(spec: Spec) -> str:
    return f"{spec.doc} [{spec.unit}]" if spec.unit and spec.unit != "1" else spec.doc


def _json_default(value):
    return [_json_default(v) for v in value] if isinstance(value, tuple) else value


def table_schema(cls, key: str | None = None, kind: str | None = None) -> dict:
    """JSON schema of one table; ``key``/``kind`` pin the discriminating field of a variant."""
    properties: dict = {}
    required: list[str] = []
    if key is not None:
        properties[key] = {"const": kind, "description": (cls.__doc__ or "").strip().splitlines()[0]}
        required.append(key)
    for field_name, spec in specs(cls).items():
        default = field_default(cls, field_name)
        schema = spec.kind.visit(_Schema, spec, default)
        schema["description"] = _describe(spec)
        properties[field_name] = schema
        if default is REQUIRED:
            required.append(field_name)
    one_of_names = []  # a field that may be given in other units (workflows.engineering_units)
    for field_name, spec in specs(cls).items():
        others = engineering_units.other_names(field_name) if spec.kind is NUMBER else []
        if spec.unit == "Pa" or field_name in engineering_units.UNIT_WEIGHTS.values():
            for other in others:
                unit = other.rsplit("_", 1)[-1] if other.endswith("pa") else "kN m-3"
                alias = {k: v for k, v in properties[field_name].items() if k not in _BOUND_KEYWORDS.values()}
                alias.pop("default", None)
                alias["description"] = f"{field_name} in {unit.replace('kpa', 'kPa').replace('mpa', 'MPa')}"
                properties[other] = alias
            if field_name in required:
                required.remove(field_name)
                one_of_names.append([field_name, *others])
    schema = {"type": "object", "description": (cls.__doc__ or "").strip().splitlines()[0]}
    schema.update(properties=properties, required=required, additionalProperties=False)
    if one_of_names:
        schema["allOf"] = [{"oneOf": [{"required": [name]} for name in names]} for names in one_of_names]
    return schema


class _Schema:
    """The JSON schema of a field, by its kind (``FieldKind.visit``): a value's with its default, a nested
    table's, an array of tables (of one class, or one of the variants by its ``key``)."""

    @staticmethod
    def value(spec: Spec, default) -> dict:
        schema = spec.kind.schema(spec)
        if default is not REQUIRED and default is not None:
            schema["default"] = _json_default(default)
        return schema

    @staticmethod
    def table(spec: Spec, default) -> dict:
        return table_schema(spec.of)

    @staticmethod
    def tables(spec: Spec, default) -> dict:
        if spec.variants:
            items = {"oneOf": [table_schema(c, spec.key, k) for k, c in spec.variants.items()]}
        else:
            items = table_schema(spec.of)
        return {"type": "array", "items": items, "minItems": spec.min_items}


def json_schema() -> dict:
    """The JSON schema of a study file (draft 2020-12)."""
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": "spfem-fos study file"}
    schema.update(table_schema(Study))
    return schema


# ---------------------------------------------------------------------------------------
# Markdown
# ---------------------------------------------------------------------------------------


def reference_rows(cls=Study, prefix: str = "", only: str = "") -> list[list[str]]:
    """One row per field: path, type, unit, default, allowed values, description."""
    rows = []
    for field_name, spec in specs(cls).items():
        path = f"{prefix}.{field_name}" if prefix else field_name
        rows += spec.kind.visit(_Rows, spec, path, field_default(cls, field_name), only)
    return rows


class _Rows:
    """The reference's rows of a field, by its kind (``FieldKind.visit``): a value's one row (``only``: the
    variant it belongs to), a nested table's fields, an array of tables' (with its variants' own)."""

    @staticmethod
    def value(spec: Spec, path: str, default, only: str) -> list[list[str]]:
        shown = "required" if default is REQUIRED else ("" if default is None else f"`{show(default)}`")
        unit = "" if spec.unit == "1" else spec.unit
        doc = f"*{only}:* {spec.doc}" if only else spec.doc
        return [[f"`{path}`", spec.kind.shown, unit, shown, spec.kind.allowed(spec), doc]]

    @staticmethod
    def table(spec: Spec, path: str, default, only: str) -> list[list[str]]:
        return reference_rows(spec.of, path)

    @staticmethod
    def tables(spec: Spec, path: str, default, only: str) -> list[list[str]]:
        entry = f"{path}[]"
        if not spec.variants:
            return reference_rows(spec.of, entry)
        kinds = ", ".join(f"`{k}`" for k in spec.variants)
        return [[f"`{entry}.{spec.key}`", "string", "", "required", kinds, spec.key_doc], *_variant_rows(spec, entry)]


def _variant_rows(spec: Spec, entry: str) -> list[list[str]]:
    """Rows of an array of tables with kinds: shared fields once, the others per kind."""
    per_kind = {kind: reference_rows(cls, entry, only=f"{spec.key} = {kind}") for kind, cls in spec.variants.items()}
    plain = {kind: reference_rows(cls, entry) for kind, cls in spec.variants.items()}
    shared = [row for row in next(iter(plain.values())) if all(row in rows for rows in plain.values())]
    rows = list(shared)
    for kind, kind_rows in per_kind.items():
        rows += [row for row, plain_row in zip(kind_rows, plain[kind]) if plain_row not in shared]
    return rows


def markdown_table() -> str:
    """The Markdown reference of every field of a study file."""
    header = ["Field", "Type", "Unit", "Default", "Allowed", "Description"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |" for row in reference_rows()]
    intro = (
        "Empty default: optional, absent unless given. `[]` marks an array of tables "
        "(`[[stages]]`); entries are numbered from 0 in error messages."
    )
    return intro + "\n\n" + "\n".join(lines) + "\n"


PAGE_INTRO = """\
# Study-file reference

A study file is a TOML file with the tables `[study]`, `[geometry]`, `[[materials]]`, `[loads]`,
`[water]`, `[[boundary]]`, `[[walls]]`, `[solver]`, `[[stages]]`, `[[monitors]]`, `[metrics]`,
`[output]` and `[sweep]`.
Stages run in order, each continuing from the state the previous one left; a study whose last
stage is a `strength_reduction` stage computes a factor of safety; a `runout` stage follows a
failure to rest and measures it.  Every field is checked before
anything runs: a bad value is one line `error: <file>: <field>: <problem>` and exit code 2.
Units are UDUNITS strings, as in the result files (`docs/result-files.md`).

**Slope form.**  Instead of `geometry.polygon_m`, a `[geometry.slope]` table describes a slope
by its dimensions: flat ground behind the crest, the face, flat ground beyond the toe, on a
foundation down to a fixed base at y = 0, the crest on the left.  It makes the polygon and,
when the study gives none, the supports (a fixed `base`, a roller `left` behind the crest and,
with a foundation, a roller `right` at its far end) and the monitors `crest` and `toe`.  With
`layer_depths_m`, the materials without `region_m` fill the layers from the top.

```toml
[geometry]
spacing_m = 0.5

[geometry.slope]
height_m = 10.0
angle_deg = 35.0           # or gradient = 2.0 (1V:2H)
foundation_depth_m = 5.0   # default H / 2; 0: a firm base at the toe
```

**Section drawn as lines.**  A `[geometry.section]` table draws the section as engineers do:
the ground surface as a line from left to right (its ends are the section's sides), the level
of the fixed base, and each layer by the line it lies below (`below_m`), above (`above_m`) or
between (the two may meet, as a lens pinching out; a line may dip under the base).  The code
closes them into the polygon and the materials' regions; a material that no layer places and
that gives no `region_m` fills the rest.  When the study gives no
`[[boundary]]`, the base is fixed (`base`) and both sides are rollers (`left`, `right`).  A peak
of the ground (or of a polygon's top) less than one spacing wide one spacing below its top, a
survey's spike, is refused: no particle fills it, yet it would count in the slope's height.

```toml
[geometry.section]
ground_m = [[20.0, 25.0], [30.0, 25.0], [50.0, 35.0], [70.0, 35.0]]
base_y_m = 20.0

[[geometry.section.layers]]
material = "clay"                        # a [[materials]] entry, without region_m
below_m = [[30.0, 25.0], [50.0, 29.0], [70.0, 31.0]]
above_m = [[40.0, 27.0], [52.0, 24.0], [70.0, 24.0]]
```

**Engineering units.**  Every field in Pa (`<name>_pa`) may be given in kPa (`<name>_kpa`) or
MPa (`<name>_mpa`) instead, and a material's `density_kg_m3` and `saturated_density_kg_m3` by
its unit weight in kN/m3 (`unit_weight_kn_m3`, `saturated_unit_weight_kn_m3`; rho = 1000 gamma / |g|
with g from `loads.gravity_m_s2`): `cohesion_kpa = 10.0`, `youngs_modulus_mpa = 100.0`,
`unit_weight_kn_m3 = 20.0`.  The name says the unit, never the size of the number; the results
are in SI units.  A sweep axis names the SI field (`materials.soil.cohesion_pa`).

**Lines from files.**  Every line field (`[[x, y], ...]` or file in the table below: the
section's lines and the phreatic lines) may name a file instead, relative to the study file:
`"ground.csv"` (two columns x, y in m, a header row skipped; comma, semicolon or tab) or
`"section.dxf#GROUND"` (the one LWPOLYLINE, POLYLINE or LINE on the DXF layer `GROUND`, any case,
drawn in either direction, in world coordinates as CAD shows it, mirrored or not; its arcs as
chords no further than 1e-4 of the line's width or height from the arc, 1 cm on a 100 m section;
a drawing whose `$INSUNITS` is not metres (6) or unitless (0) is refused: scale it to metres).
The points are read when the study is loaded, and the study text kept with the results has them
written out.

**Water and loads.**  `[water]` sets the pore pressure u in the ground from a piezometric line
(`phreatic_line_m`, or a horizontal `phreatic_level_m`; a material may have its own
`phreatic_line_m`) or from `ru`, and `pond_level_m` puts
water on the ground surface (drained, steady water: the line stays where it is while the ground
deforms).  The particles carry the effective stress, which the yield function sees; equilibrium
is in total stress, with the weight of each particle from `density_kg_m3` above the line and
`saturated_density_kg_m3` at or below it.  Strength reduction divides c' and tan(phi') only.
`[[loads.strip]]` and `[[loads.line]]` put vertical loads on the ground surface from the first
stage on; `[loads.seismic]` adds the pseudo-static body force kh g (towards the free face by
default) and kv g (upward for kv > 0) in the strength-reduction runs.

```toml
[water]
phreatic_level_m = 6.0       # or phreatic_line_m = [[0.0, 9.0], [30.0, 6.0], [60.0, 5.0]]
pond_level_m = 6.0           # water standing on the face below 6 m

[[loads.strip]]
name = "surcharge"
x_start_m = 2.0
x_end_m = 8.0
pressure_pa = 20e3

[loads.seismic]
horizontal_coefficient = 0.1
```

**Sweeps.**  A `[sweep]` table turns a strength-reduction study into a parameter study: the
study runs once per case, with the swept fields set to the case's values, and every case's
FOS lands in `OUT/study.nc` over one dimension per axis (`docs/result-files.md`).  An axis names
a field by its path: tables by their name (`solver.cfl`), entries of arrays of tables by their
`name` (`materials.soil.cohesion_pa`, `stages.srf.duration_s`, `boundary.base.vx_m_s`,
`loads.strip.surcharge.pressure_pa`), the slope form as `geometry.slope.<field>`, the water level
as `water.phreatic_level_m` (with `water.pond_level_m` in a `zip`), the seismic coefficient as
`loads.seismic.horizontal_coefficient`.  Each value is checked as the field itself is, and so
is each case as a whole study: an error names the axis, the value or the case.  `grid` runs
every combination (the last axis varies fastest), `zip` the i-th values of all axes together.
A study without a strength_reduction stage (a runout, a collapse) can be swept too: each case's
stages run in the study's process on all cores, one case after another, and `OUT/study.nc` holds
their runout metrics (and collapse metrics) instead of a FOS
(`studies/runout_residual_friction_sweep.toml`).

```toml
[sweep]
combination = "grid"

[[sweep.axes]]
path = "materials.soil.cohesion_pa"
values = [5e3, 10e3, 15e3]

[[sweep.axes]]
path = "geometry.slope.angle_deg"
start = 25.0
stop = 45.0
count = 5
```

**Refinement.**  A `[refinement]` table turns a strength-reduction study into a refinement
study: the FOS at a sequence of particle spacings (`spacings_m`, or `levels` spacings from
`geometry.spacing_m` in steps of `ratio`), each level with the search tolerance `fos_tolerance`
and, after the first, a search window around the FOS of the level before; from the three finest
levels the observed order, the FOS at h -> 0 (Richardson) and the grid convergence index as its
band, in `OUT/refinement.nc` and `convergence.png` (docs/method.md, section 9).  With `[sweep]`,
every case is refined (each in `OUT/cases/<case>/`, the levels of all cases advancing together) and
`OUT/study.nc` adds each case's FOS at h -> 0 and band.

```toml
[refinement]
spacings_m = [1.0, 0.7071, 0.5]
```

**Probabilistic.**  A `[probabilistic]` table runs a strength-reduction study once per realisation
of its random variables (any number field, by its path as in `[sweep]`; normal, lognormal, uniform
or truncated normal, correlated through a Gaussian copula with the correlation asked of the
variables themselves), drawn by Monte Carlo (realisation i the same whatever the count: extending
a study computes only the new ones) or a Latin hypercube.  Each realisation is judged stable or
failed by its run at `factor` (`compute = "verdict"`) or by its own FOS (`"fos"`); `OUT/probabilistic.nc`
holds every realisation and pf with its exact 95% interval.  Random fields are not available yet.

```toml
[probabilistic]
realisations = 200
[[probabilistic.variables]]
path = "materials.soil.cohesion_pa"
distribution = "lognormal"
cov = 0.3
```
"""


def page() -> str:
    """The whole reference page (``docs/study-file.md``)."""
    note = f"<!-- generated from workflows/study/tables.py by `{REGENERATE}`; do not edit -->"
    return f"{note}\n{PAGE_INTRO}\n{markdown_table()}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m workflows.study.reference", description=__doc__.splitlines()[0])
    parser.add_argument("--json-schema", action="store_true", help="print the JSON schema instead of the page")
    args = parser.parse_args(argv)
    sys.stdout.write(json.dumps(json_schema(), indent=2) + "\n" if args.json_schema else page())


if __name__ == "__main__":
    main()
