"""Fields in engineers' units (workflows.engineering_units): kPa and MPa for any field in
Pa, unit weights in kN/m3 for densities; the study they make is the SI one, and errors name the
field as written."""

from __future__ import annotations

import math
import tomllib

import jsonschema
import pytest

from verification.study_text import gravity, gravity_stage, slope_form, srf_stage, study_text
from workflows.study import StudyError, parse_study, reference
from workflows.study.reading import sweep_cases
from workflows.study.toml_text import to_toml

SI = study_text(
    "units", {"spacing_m": 1.0, "slope": slope_form(10.0, 2.0)},
    [{"name": "soil", "model": "mohr_coulomb", "density_kg_m3": 2000.0, "saturated_density_kg_m3": 2100.0,
      "youngs_modulus_pa": 100e6, "poisson_ratio": 0.3, "cohesion_pa": 10e3, "friction_deg": 20.0,
      "tensile_strength_pa": 2e3}],
    [gravity_stage(20.0, 0.05), srf_stage(5.0, 0.05)],
    water={"phreatic_level_m": 6.0},
    loads={**gravity(), "strip": [{"name": "surcharge", "x_start_m": 2.0, "x_end_m": 8.0, "pressure_pa": 20e3}]})

ENGINEERING = {"density_kg_m3": ("unit_weight_kn_m3", 20.0),
               "saturated_density_kg_m3": ("saturated_unit_weight_kn_m3", 21.0),
               "youngs_modulus_pa": ("youngs_modulus_mpa", 100.0),
               "cohesion_pa": ("cohesion_kpa", 10.0),
               "tensile_strength_pa": ("tensile_strength_kpa", 2.0)}


def _engineering() -> dict:
    raw = tomllib.loads(SI)
    material = raw["materials"][0]
    for si, (name, value) in ENGINEERING.items():
        del material[si]
        material[name] = value
    strip = raw["loads"]["strip"][0]
    del strip["pressure_pa"]
    strip["pressure_kpa"] = 20.0
    return raw


def test_engineering_units_make_the_si_study():
    si, engineering = parse_study(SI), parse_study(to_toml(_engineering()))
    assert engineering.materials == si.materials
    assert engineering.loads == si.loads


def test_the_json_schema_takes_either_form_but_not_both_nor_neither():
    schema = reference.json_schema()
    for raw in (tomllib.loads(SI), _engineering()):
        jsonschema.validate(raw, schema, cls=jsonschema.Draft202012Validator)
    for change in ({"cohesion_pa": 1.0}, {"density_kg_m3": None}):
        raw = _engineering()
        for key, value in change.items():
            if value is None:
                del raw["materials"][0]["unit_weight_kn_m3"]
            else:
                raw["materials"][0][key] = value
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(raw, schema, cls=jsonschema.Draft202012Validator)


@pytest.mark.parametrize(
    "change, field, words",
    [
        ({"cohesion_kpa": -1.0}, "materials[0].cohesion_kpa", "must be >= 0"),
        ({"cohesion_kpa": "10"}, "materials[0].cohesion_kpa", "must be a number"),
        ({"cohesion_pa": 10e3}, "materials[0].cohesion_kpa", "not both"),
        ({"density_kg_m3": 2000.0}, "materials[0].unit_weight_kn_m3", "not both"),
        ({"unit_weight_kn_m3": 0.0}, "materials[0].unit_weight_kn_m3", "> 0"),
        ({"cohesion_gpa": 1.0}, "materials[0].cohesion_gpa", "unknown field"),
        ({"friction_kpa": 1.0}, "materials[0].friction_kpa", "unknown field"),
        # an integer too large for a float: refused as cohesion_pa refuses it, not an OverflowError
        ({"cohesion_kpa": 10**400}, "materials[0].cohesion_kpa", "must be finite, got an integer of 401 digits"),
        ({"youngs_modulus_mpa": -(10**400)}, "materials[0].youngs_modulus_mpa", "must be finite"),
        ({"unit_weight_kn_m3": 10**400}, "materials[0].unit_weight_kn_m3", "must be finite"),
        ({"saturated_unit_weight_kn_m3": 10**400}, "materials[0].saturated_unit_weight_kn_m3", "must be finite"),
    ],
)
def test_errors_name_the_field_as_written(change, field, words):
    raw = _engineering()
    raw["materials"][0].update(change)
    with pytest.raises(StudyError) as error:
        parse_study(to_toml(raw))
    assert error.value.field == field and words in error.value.problem


def test_a_density_check_names_the_unit_weight():
    raw = _engineering()
    del raw["water"]
    with pytest.raises(StudyError, match="below a piezometric line") as error:
        parse_study(to_toml(raw))
    assert error.value.field == "materials[0].saturated_unit_weight_kn_m3"


def test_a_unit_weight_needs_gravity():
    raw = _engineering()
    raw["loads"]["gravity_m_s2"] = [0.0, 0.0]
    with pytest.raises(StudyError, match="needs gravity") as error:
        parse_study(to_toml(raw))
    assert error.value.field == "materials[0].unit_weight_kn_m3"


@pytest.mark.parametrize("gravity, words", [([0.0, math.nan], "must be finite, got nan"),
                                            ([0.0, "down"], "must be a number"),
                                            ([1e200, -1e200], "must be at most")])
def test_a_unit_weight_with_a_bad_gravity_names_the_gravity(gravity, words):
    raw = _engineering()
    raw["loads"]["gravity_m_s2"] = gravity
    with pytest.raises(StudyError, match=words) as error:
        parse_study(to_toml(raw))
    assert error.value.field == "loads.gravity_m_s2"


def test_a_sweep_of_the_si_field_replaces_the_engineering_one():
    raw = _engineering()
    raw["sweep"] = {"axes": [{"path": "materials.soil.cohesion_pa", "values": [5e3, 15e3]}]}
    cases = sweep_cases(parse_study(to_toml(raw)))
    assert [case.study.materials[0].cohesion_pa for case in cases] == [5e3, 15e3]
    assert {case.study.materials[0].density_kg_m3 for case in cases} == {2000.0}


def test_a_unit_weight_takes_the_default_gravity():
    raw = _engineering()
    del raw["loads"]["gravity_m_s2"]
    raw["materials"][0]["unit_weight_kn_m3"] = 9.81
    assert parse_study(to_toml(raw)).materials[0].density_kg_m3 == pytest.approx(1000.0)


@pytest.mark.parametrize("path, si_field, si_per_unit", [
    ("materials.soil.cohesion_kpa", "cohesion_pa", 1e3),
    ("materials.soil.cohesion_pa", "cohesion_pa", 1.0),
    ("materials.soil.cohesion_mpa", "cohesion_pa", 1e6),
    ("materials.soil.unit_weight_kn_m3", "density_kg_m3", 1000.0 / 10.0),  # |g| = 10 m/s2 in this study
    ("materials.soil.density_kg_m3", "density_kg_m3", 1.0),
])
def test_a_random_variable_takes_either_spelling_of_a_field_in_the_unit_it_names(path, si_field, si_per_unit):
    """The file in kPa and kN/m3, a random variable by either spelling of the field's path: its mean
    is the file's value in the path's unit, its draws are in that unit (the sampler's, from that mean
    and COV), and each realisation holds the field in that one spelling, the SI value the draw times
    the unit."""
    from workflows.distributions import LOGNORMAL
    from workflows.probabilistic.sampling import Marginal, Sampler
    from workflows.probabilistic.study_type import realisation_cases

    raw = _engineering()
    raw["probabilistic"] = {"realisations": 3, "seed": 5,
                            "variables": [{"path": path, "distribution": "lognormal", "cov": 0.1}]}
    cases = realisation_cases(parse_study(to_toml(raw)))
    mean = getattr(parse_study(SI).materials[0], si_field) / si_per_unit
    label = path.split(".")[-1]
    draws = Sampler([Marginal(LOGNORMAL, mean, 0.1 * mean)]).monte_carlo(5, range(3))[:, 0]
    assert [case.values[label] for case in cases] == pytest.approx(draws, rel=1e-12)
    for case, draw in zip(cases, draws):
        assert getattr(case.study.materials[0], si_field) == pytest.approx(draw * si_per_unit, rel=1e-12)
        written = tomllib.loads(case.study.source_text)["materials"][0]
        same = ("cohesion_pa", "cohesion_kpa", "cohesion_mpa") if si_field == "cohesion_pa" else (
            "density_kg_m3", "unit_weight_kn_m3")
        assert [name for name in same if name in written] == [label]


def test_a_sweep_takes_a_field_in_kpa_and_its_results_say_so():
    """[sweep] over materials.soil.cohesion_kpa: values in kPa checked against the field's range in kPa,
    each case the SI study, and study.nc's coordinate in kPa."""
    from workflows.sweep.results import sweep_coordinates

    raw = _engineering()
    raw["sweep"] = {"axes": [{"path": "materials.soil.cohesion_kpa", "values": [5.0, 15.0]}]}
    study = parse_study(to_toml(raw))
    cases = sweep_cases(study)
    assert [case.study.materials[0].cohesion_pa for case in cases] == [5e3, 15e3]
    assert sweep_coordinates(study, cases)[2]["cohesion_kpa"][2]["units"] == "kPa"
    raw["sweep"]["axes"][0]["values"] = [-1.0, 15.0]
    with pytest.raises(StudyError, match="must be >= 0, got -1") as error:
        parse_study(to_toml(raw))
    assert error.value.field == "sweep.axes[0].values[0]"
