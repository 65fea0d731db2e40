"""The study file: shipped studies load, malformed ones fail with a one-line message naming
the field, and the JSON schema, Markdown reference and README block cover every field."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given
from hypothesis import strategies as st

from spfem_core.cloud import MAX_JITTER
from workflows.fields import TABLE, TABLES, specs
from workflows.materials import ElasticMaterial
from workflows.stages import DynamicStage, RelaxationStage
from workflows.study import StudyError, load_study, parse_study, reference
from workflows.study.geometry import Geometry
from workflows.study.tables import Study

REPO = Path(__file__).resolve().parents[1]
SHIPPED_STUDIES = sorted((REPO / "studies").glob("*.toml"))

BASE = """\
[study]
name = "beam"

[geometry]
polygon_m = [[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]]
spacing_m = 0.02

[[materials]]
name = "beam"
model = "elastic"
density_kg_m3 = 1850.0
youngs_modulus_pa = 80e6
poisson_ratio = 0.25

[[boundary]]
name = "clamp"
x_max_m = 0.0
vx_m_s = 0.0
vy_m_s = 0.0

[solver]
cfl = 0.5

[[stages]]
name = "vibration"
kind = "dynamic"
duration_s = 4.0
record_interval_s = 0.001

[[monitors]]
name = "tip"
x_m = 2.0
y_m = 0.2
"""

SECOND_MONITOR = '\n[[monitors]]\nname = "tip"\nx_m = 1.0\ny_m = 0.1\n'


def variant(old: str, new: str) -> str:
    """BASE with ``old`` replaced by ``new`` (which must occur exactly once)."""
    assert BASE.count(old) == 1, old
    return BASE.replace(old, new)


def study_error(text: str) -> str:
    with pytest.raises(StudyError) as caught:
        parse_study(text)
    message = str(caught.value)
    assert "\n" not in message
    return message


# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("path", SHIPPED_STUDIES, ids=lambda p: p.name)
def test_shipped_studies_load(path):
    study = load_study(path)
    assert study.name == path.stem
    assert study.source_text == path.read_text()
    assert study.stages and study.monitors


def test_cantilever_beam_is_espfem2d_example_1():
    study = load_study(REPO / "studies" / "cantilever_beam.toml")
    (material,) = study.materials
    assert isinstance(material, ElasticMaterial)
    assert (material.density_kg_m3, material.youngs_modulus_pa, material.poisson_ratio) == (1850.0, 80e6, 0.25)
    assert study.geometry.spacing_m == 0.02
    assert study.loads.gravity_m_s2 == (0.0, -9.8)
    assert study.solver.stabilisation_beta == 0.1
    (stage,) = study.stages
    assert isinstance(stage, DynamicStage) and stage.duration_s == 4.0 and stage.damping == 0.0
    assert [(m.name, m.x_m, m.y_m) for m in study.monitors] == [("tip", 2.0, 0.2)]


def test_defaults_and_types():
    study = parse_study(BASE.replace("[solver]\ncfl = 0.5\n", ""))
    assert study.loads.gravity_m_s2 == (0.0, -9.81)
    assert study.solver.cfl is None and study.solver.dt_s is None and study.solver.alpha == 1.5
    assert study.geometry.jitter == 0.0 and study.geometry.seed == 0
    assert study.geometry.polygon_m[1] == (2.0, 0.0)
    assert study.stages[0].damping == 0.0
    assert study.boundary[0].y_min_m is None and study.boundary[0].vx_m_s == 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        study.geometry.spacing_m = 1.0


def test_relaxation_stage_defaults_to_local_damping():
    text = variant('kind = "dynamic"\nduration_s = 4.0', 'kind = "relaxation"\nmax_duration_s = 4.0')
    (stage,) = parse_study(text).stages
    assert isinstance(stage, RelaxationStage)
    assert stage.damping == 0.7 and stage.tolerance == 1e-5 and stage.kind == "relaxation"


def test_integer_accepted_for_a_float():
    study = parse_study(variant("record_interval_s = 0.001", "record_interval_s = 1"))
    assert study.stages[0].record_interval_s == 1.0 and type(study.stages[0].record_interval_s) is float


MALFORMED = {
    "unknown top-level key": (variant("[study]", "colour = 1\n[study]"), "colour", "unknown field"),
    "unknown table": (BASE + "\n[extras]\nx = 1\n", "extras", "unknown field"),
    "unknown nested key": (variant("spacing_m = 0.02", "spacing = 0.02"), "geometry.spacing", "did you mean 'spacing_m'"),
    "unknown key in array": (variant('name = "tip"', 'name = "tip"\nz_m = 0.0'), "monitors[0].z_m", "unknown field"),
    "wrong type": (variant("spacing_m = 0.02", 'spacing_m = "0.02"'), "geometry.spacing_m", 'must be a number, got "0.02"'),
    "bool for a number": (
        variant("youngs_modulus_pa = 80e6", "youngs_modulus_pa = true"),
        "materials[0].youngs_modulus_pa",
        "must be a number, got true",
    ),
    "bool for an integer": (variant("spacing_m = 0.02", "spacing_m = 0.02\nseed = false"), "geometry.seed", "integer"),
    "float for an integer": (variant("spacing_m = 0.02", "spacing_m = 0.02\nseed = 1.5"), "geometry.seed", "integer"),
    "negative spacing": (variant("spacing_m = 0.02", "spacing_m = -0.1"), "geometry.spacing_m", "must be > 0, got -0.1"),
    "nan spacing": (variant("spacing_m = 0.02", "spacing_m = nan"), "geometry.spacing_m", "finite"),
    "nu = 0.5": (variant("poisson_ratio = 0.25", "poisson_ratio = 0.5"), "materials[0].poisson_ratio", "< 0.5"),
    "zero density": (variant("density_kg_m3 = 1850.0", "density_kg_m3 = 0.0"), "materials[0].density_kg_m3", ">= 1"),
    "missing required field": (
        variant("density_kg_m3 = 1850.0\n", ""),
        "materials[0].density_kg_m3",
        "required field missing",
    ),
    "missing required table": (variant("[geometry]", "[geometry_m]"), "geometry_m", "unknown field"),
    "no stages": (BASE[: BASE.index("[[stages]]")], "stages", "required field missing"),
    "table written as array": (variant("[geometry]", "[[geometry]]"), "geometry", "must be a table"),
    "polygon with 2 vertices": (
        variant("[[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]]", "[[0.0, 0.0], [2.0, 0.0]]"),
        "geometry.polygon_m",
        "at least 3 vertices, got 2",
    ),
    "zero-area polygon": (
        variant("[[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]]", "[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]"),
        "geometry.polygon_m",
        "zero area",
    ),
    "self-crossing polygon": (
        variant("[[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]]", "[[0.0, 0.0], [2.0, 0.2], [2.0, 0.0], [0.0, 0.2]]"),
        "geometry.polygon_m",
        "cross",
    ),
    "bad vertex": (
        variant("[[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]]", "[[0.0, 0.0], [2.0], [2.0, 0.2], [0.0, 0.2]]"),
        "geometry.polygon_m",
        "vertex 1",
    ),
    "gravity with 3 components": (BASE + "\n[loads]\ngravity_m_s2 = [0.0, -9.8, 0.0]\n", "loads.gravity_m_s2", "pair"),
    "jitter 0.3": (variant("spacing_m = 0.02", "spacing_m = 0.02\njitter = 0.3"), "geometry.jitter", "< 0.3"),
    "unknown model": (variant('model = "elastic"', 'model = "plastic"'), "materials[0].model", 'got "plastic"'),
    "missing model": (variant('model = "elastic"\n', ""), "materials[0].model", "required field missing"),
    "unknown stage kind": (variant('kind = "dynamic"', 'kind = "static"'), "stages[0].kind", '"dynamic", "relaxation"'),
    "field of another stage kind": (
        variant("duration_s = 4.0", "duration_s = 4.0\ntolerance = 1e-5"),
        "stages[0].tolerance",
        "unknown field",
    ),
    "record interval > duration": (
        variant("record_interval_s = 0.001", "record_interval_s = 5.0"),
        "stages[0].record_interval_s",
        "must be <= duration_s = 4, got 5",
    ),
    "zero duration": (variant("duration_s = 4.0", "duration_s = 0.0"), "stages[0].duration_s", "> 0"),
    "stage name with a space": (variant('name = "vibration"', 'name = "free vibration"'), "stages[0].name", "letters"),
    "monitor outside polygon": (variant("x_m = 2.0", "x_m = 2.5"), "monitors[0]", "outside geometry.polygon_m"),
    "cfl 0": (variant("cfl = 0.5", "cfl = 0"), "solver.cfl", "must be > 0, got 0"),
    "cfl 1.5": (variant("cfl = 0.5", "cfl = 1.5"), "solver.cfl", "must be <= 1, got 1.5"),
    "cfl and dt": (variant("cfl = 0.5", "cfl = 0.5\ndt_s = 1e-5"), "solver.dt_s", "not both"),
    "alpha below 1": (variant("cfl = 0.5", "cfl = 0.5\nalpha = 0.9"), "solver.alpha", ">= 1"),
    "negative beta": (variant("cfl = 0.5", "cfl = 0.5\nstabilisation_beta = -0.1"), "solver.stabilisation_beta", ">= 0"),
    "boundary without velocity": (variant("vx_m_s = 0.0\nvy_m_s = 0.0\n", ""), "boundary[0].vx_m_s", "prescribe"),
    "boundary box inverted": (
        variant("x_max_m = 0.0", "x_min_m = 1.0\nx_max_m = 0.0"),
        "boundary[0].x_max_m",
        "must be >= x_min_m",
    ),
    "duplicate monitor names": (BASE + SECOND_MONITOR, "monitors[1].name", 'duplicate name "tip" (also monitors[0])'),
    "TOML syntax error": (variant("spacing_m = 0.02", "spacing_m 0.02"), "line 6, column 11", "Expected '='"),
}


@pytest.mark.parametrize("case", MALFORMED, ids=list(MALFORMED))
def test_malformed_study_names_the_field(case):
    text, field, fragment = MALFORMED[case]
    message = study_error(text)
    assert message.startswith(field + ": "), message
    assert fragment in message, message


GRANULAR = (REPO / "studies" / "collapse_granular.toml").read_text()


@pytest.mark.parametrize("change, field, fragment", [
    (("[[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]]", "[[0.0, 0.0], [0.4, 0.0], [0.4, 0.1], [0.0, 0.1]]"),
     "metrics.kind", "a 0.2 x 0.1 m column; this domain is 0.4 x 0.1 m"),
    (("[[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]]", "[[0.5, 0.0], [0.7, 0.0], [0.7, 0.1], [0.5, 0.1]]"),
     "metrics", "a wall at x = 0 and a base at y = 0; the domain starts at x = 0.5 m"),
    (("[metrics]", '[[stages]]\nname = "settle"\nkind = "relaxation"\nmax_duration_s = 1.0\nrecord_interval_s = 0.01\n\n[metrics]'),
     "metrics", "the last stage 'settle' is a relaxation stage"),
])
def test_collapse_metrics_refuse_what_they_cannot_measure(change, field, fragment):
    """The metrics assume a collapse (a dynamic last stage) from a wall at x = 0 on a base at y = 0;
    ``granular_collapse`` compares with the experiment's 0.2 x 0.1 m column."""
    assert parse_study(GRANULAR).metrics.kind == "granular_collapse"
    with pytest.raises(StudyError) as error:
        parse_study(GRANULAR.replace(*change))
    assert str(error.value).startswith(field + ": ") and fragment in str(error.value), str(error.value)


def test_error_message_is_field_colon_problem():
    assert study_error(variant("spacing_m = 0.02", "spacing_m = -0.1")) == "geometry.spacing_m: must be > 0, got -0.1"


def test_study_file_executes_nothing(tmp_path):
    marker = tmp_path / "marker"
    code = f"__import__('os').mkdir('{marker}')"
    text = variant('[study]\nname = "beam"', f'[study]\nname = "beam"\ndescription = "{code}"')
    parse_study(text)
    assert not marker.exists()


def toml_literal(value) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return repr(value) if isinstance(value, float) else json.dumps(value)


@given(
    st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-(10**6), max_value=10**6),
        st.booleans(),
        st.text(alphabet=st.characters(codec="ascii", exclude_categories=("Cc",)), max_size=5),
    )
)
def test_any_spacing_loads_or_names_the_field(value):
    text = variant("spacing_m = 0.02", f"spacing_m = {toml_literal(value)}")
    try:
        study = parse_study(text)
    except StudyError as error:
        assert str(error).startswith("geometry.spacing_m: ") and "\n" not in str(error)
    else:
        assert study.geometry.spacing_m > 0


# ---------------------------------------------------------------------------------------
# Generated reference
# ---------------------------------------------------------------------------------------


def field_paths(cls=Study, prefix=""):
    """Every leaf field as (dotted path, table dataclass, field name)."""
    for name, spec in specs(cls).items():
        path = f"{prefix}.{name}" if prefix else name
        if spec.kind is TABLE:
            yield from field_paths(spec.of, path)
        elif spec.kind is TABLES:
            if spec.key:
                yield f"{path}[].{spec.key}", cls, spec.key
            for entry_cls in spec.variants.values() or [spec.of]:
                yield from field_paths(entry_cls, f"{path}[]")
        else:
            yield path, cls, name


def schema_at(schema: dict, path: str) -> list[dict]:
    """The property schemas a dotted path reaches (several through oneOf)."""
    nodes = [schema]
    for part in path.split("."):
        entry = part.endswith("[]")
        part = part.removesuffix("[]")
        found = []
        for node in nodes:
            for option in node.get("oneOf", [node]):
                if part in option.get("properties", {}):
                    child = option["properties"][part]
                    found.append(child["items"] if entry else child)
        nodes = found
    return nodes


def test_json_schema_is_valid_and_lists_every_field():
    output = subprocess.run(
        [sys.executable, "-m", "workflows.study.reference", "--json-schema"], capture_output=True, text=True, check=True, cwd=REPO
    ).stdout
    schema = json.loads(output)
    jsonschema.Draft202012Validator.check_schema(schema)
    paths = list(field_paths())
    assert len(paths) > 25
    for path, _, _ in paths:
        assert schema_at(schema, path), path


@pytest.mark.parametrize("path", SHIPPED_STUDIES, ids=lambda p: p.name)
def test_shipped_studies_satisfy_the_json_schema(path):
    jsonschema.validate(tomllib.loads(path.read_text()), reference.json_schema(), cls=jsonschema.Draft202012Validator)


def test_json_schema_rejects_what_the_loader_rejects():
    schema = reference.json_schema()
    for case in ("unknown nested key", "bool for a number", "unknown stage kind", "cfl 1.5", "nu = 0.5"):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(tomllib.loads(MALFORMED[case][0]), schema, cls=jsonschema.Draft202012Validator)


def test_reference_page_mentions_every_field():
    output = subprocess.run(
        [sys.executable, "-m", "workflows.study.reference"], capture_output=True, text=True, check=True, cwd=REPO
    ).stdout
    assert output == reference.page()
    for path, _, _ in field_paths():
        assert f"`{path}`" in output, path


def test_study_file_reference_in_docs_is_up_to_date():
    page = (REPO / "docs" / "study-file.md").read_text(encoding="utf-8")
    assert page == reference.page(), f"docs/study-file.md is stale: run {reference.REGENERATE}"


def test_jitter_bound_is_the_cloud_generator_s():
    assert specs(Geometry)["jitter"].lt == MAX_JITTER
