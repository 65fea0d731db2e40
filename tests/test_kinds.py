"""Kinds as types: each kind of thing the study file names by a string is one object of its
registry, asked for its behaviour; the study file's text and its refusals stay as they were."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from workflows.study import StudyError, parse_study

STUDIES = Path(__file__).resolve().parents[1] / "studies"
RUNOUT = (STUDIES / "runout_reference_slope.toml").read_text()
SRF_STAGE = """[[stages]]
name = "fos"
kind = "strength_reduction"
duration_s = 5.0
record_interval_s = 0.01
srf_min = 1.0
srf_max = 2.0
srf_step = 0.1

[output]"""
REFINED_ZONE = ('spacing_m = 0.3\nrefined = [{name = "z", region_m = [[10.0, 5.0], [30.0, 5.0], [30.0, 15.0], '
                '[10.0, 15.0]], spacing_m = 0.15}]')


def refusal(text: str) -> str:
    with pytest.raises(StudyError) as caught:
        parse_study(text)
    return str(caught.value)


def test_a_stage_that_follows_a_runout_says_so():
    """The runout stage answers for itself where the study's checks ask (not its kind's name)."""
    study = parse_study(RUNOUT)
    assert [stage.follows_runout for stage in study.stages] == [False, True, True]
    assert refusal(RUNOUT.replace("[output]", SRF_STAGE)) == (
        "stages: runout stages and a strength_reduction stage belong in separate studies")
    assert refusal(RUNOUT.replace("spacing_m = 0.3", REFINED_ZONE)).startswith(
        "geometry.refined: refined zones apply to gravity and strength-reduction studies")


def test_collapse_metrics_are_a_kind_of_their_registry():
    """``[metrics] kind`` names one object of ``COLLAPSE_KINDS``, which checks the domain it measures."""
    from workflows.collapse.kinds import COLLAPSE_KINDS, CohesiveCollapse, GranularCollapse

    granular = parse_study((STUDIES / "collapse_granular.toml").read_text())
    assert isinstance(granular.metrics.collapse, GranularCollapse)
    assert isinstance(parse_study((STUDIES / "collapse_cohesive.toml").read_text()).metrics.collapse, CohesiveCollapse)
    assert set(COLLAPSE_KINDS) == {"granular_collapse", "cohesive_collapse"}
    with pytest.raises(StudyError, match="^metrics.kind: granular_collapse compares the deposit"):
        COLLAPSE_KINDS["granular_collapse"].check_domain((0.3, 0.1), 1e-6)
    COLLAPSE_KINDS["cohesive_collapse"].check_domain((0.3, 0.1), 1e-6)


QUICKSTART = (STUDIES / "quickstart.toml").read_text()
BASE = 'name = "base"\ny_max_m = 0.0\nvx_m_s = 0.0\nvy_m_s = 0.0\n'


@pytest.mark.parametrize("base, line", [
    ('name = "base"\ny_max_m = 0.0\nvx_m_s = 0.0\nvy_m_s = 0.1\nslip = "soil"\n',
     "boundary[0].slip: a slip support holds its prescribed direction at 0 m s-1"),
    ('name = "base"\ny_max_m = 0.0\nvy_m_s = 0.0\nslip = "welded"\n',
     "boundary[0].slip: a welded support prescribes both directions: give vx_m_s and vy_m_s"),
])
def test_each_kind_of_support_checks_its_own_velocities(base, line):
    assert refusal(QUICKSTART.replace(BASE, base)) == line


def test_each_kind_of_support_answers_the_direction_it_holds():
    """``slip`` names one object of ``SLIP_KINDS`` (left out: a rough base where it can be one)."""
    from workflows.study.supports import SLIP_KINDS

    study = parse_study(QUICKSTART.replace(BASE, BASE + 'slip = "soil"\n'))
    base = study.boundary[0]
    assert base.slip_kind is SLIP_KINDS["soil"]
    assert base.slip_kind.held_direction(base, 1) == 1
    with pytest.raises(StudyError, match="must lie on one horizontal or vertical line"):
        base.slip_kind.held_direction(base, None)
    default = parse_study(QUICKSTART).boundary[0]
    assert default.slip_kind is SLIP_KINDS[None]
    assert [default.slip_kind.held_direction(default, line) for line in (1, None)] == [1, None]
    assert [SLIP_KINDS[name].held_direction(default, 1) for name in ("none", "welded")] == [None, None]
    roller = parse_study(QUICKSTART.replace(BASE, 'name = "base"\ny_max_m = 0.0\nvy_m_s = 0.0\nslip = "soil"\n'))
    assert roller.boundary[0].slip_kind.held_direction(roller.boundary[0], None) == 1


def test_every_distribution_is_one_object_of_its_registry():
    """A study's distribution names an object of ``DISTRIBUTIONS``; a random field's point law one of
    ``FIELD_DISTRIBUTIONS``; each field law's point value and its inverse agree."""
    from workflows.distributions import DISTRIBUTIONS, FIELD_DISTRIBUTIONS, LOGNORMAL, NORMAL

    assert list(DISTRIBUTIONS) == ["normal", "lognormal", "uniform", "truncated_normal"]
    assert FIELD_DISTRIBUTIONS == {"normal": NORMAL, "lognormal": LOGNORMAL}
    for law in FIELD_DISTRIBUTIONS.values():
        assert law.gaussian_of(10.0, 3.0, law.point_value(10.0, 3.0, 0.7)) == pytest.approx(0.7)
    with pytest.raises(ValueError, match="no reliability index of a uniform F"):
        DISTRIBUTIONS["uniform"].reliability_index(1.2, 0.1)


@pytest.mark.parametrize("variable, line", [
    ('distribution = "normal"\nstd = 1.0\nlow = 0.0',
     "probabilistic.variables[0].low: applies to uniform and truncated_normal, not normal"),
    ('distribution = "uniform"\nlow = 1.0', "probabilistic.variables[0].high: a uniform variable needs low and high"),
    ('distribution = "lognormal"\ncov = 0.2\nmean = -1.0',
     "probabilistic.variables[0].mean: a lognormal variable needs a mean > 0"),
])
def test_a_variable_s_distribution_checks_what_it_is_given_by(variable, line):
    text = QUICKSTART + f'\n[probabilistic]\nrealisations = 4\n\n[[probabilistic.variables]]\npath = ' \
        f'"materials.soil.cohesion_pa"\n{variable}\n'
    assert refusal(text) == line


def test_every_correlation_model_is_one_object_of_its_registry():
    """A field's correlation_model names an object of ``CORRELATION_MODELS`` whose rho is 1 at no lag
    and falls with it; the embedding asks it for rho."""
    from workflows.random_field.correlation import CORRELATION_MODELS
    from workflows.random_field.embedding import correlation

    assert list(CORRELATION_MODELS) == ["markov", "gaussian"]
    for model in CORRELATION_MODELS.values():
        rho = correlation(model, np.array([0.0, 0.5, 1.0, 2.0]), 0.0, 1.0, 1.0)
        assert rho[0] == 1.0 and np.all(np.diff(rho) < 0.0)


def test_every_protocol_is_one_object_of_its_registry():
    """``protocol`` names an object of ``PROTOCOLS``; the optional fields are each some protocol's, the
    stage asks its protocol how a run goes and the verdict how it comes to rest."""
    from workflows.stages.protocols import PROTOCOLS
    from workflows.stages.strength_reduction import OPTIONAL_PROTOCOL_FIELDS

    assert list(PROTOCOLS) == ["quasi_static", "ramp", "sudden"]
    assert {name for protocol in PROTOCOLS.values() for name in protocol.fields} == set(OPTIONAL_PROTOCOL_FIELDS)
    assert [protocol.rest_by_unbalanced_force for protocol in PROTOCOLS.values()] == [True, False, False]
    stage = parse_study(QUICKSTART).strength_reduction
    assert stage.reduction is PROTOCOLS["quasi_static"]
    assert refusal(QUICKSTART.replace("srf_step = 0.1", 'srf_step = 0.1\nprotocol = "sudden"\nramp_time_s = 1.0')) \
        == "stages[1].ramp_time_s: applies to protocol = ramp only, not sudden"


def test_a_case_s_outcome_is_a_typed_value_a_sweep_reads(tmp_path, monkeypatch):
    """The case runner gives each case ``Concluded`` or ``Diverged`` (never the exception itself); a
    sweep records a diverged case by its flag, with the error's message, and goes on."""
    from spfem_core.divergence import DivergenceError
    from workflows.cases import Concluded, Diverged
    from workflows.stages import running
    from workflows.study_types import run_study
    from workflows.sweep.results import DIVERGED_CASE

    def diverge(study, out_dir, **kwargs):
        raise DivergenceError("velocity is not finite", step=7, time_s=0.0007)

    monkeypatch.setattr(running, "run_stages", diverge)
    beam = (STUDIES / "cantilever_beam.toml").read_text().replace("spacing_m = 0.02", "spacing_m = 0.05")
    sweep = beam + '\n[sweep]\n[[sweep.axes]]\npath = "materials.beam.youngs_modulus_pa"\nvalues = [80e6, 90e6]\n'
    outcome = run_study(parse_study(sweep), tmp_path / "out")
    assert [result.status for result in outcome.results.values()] == [DIVERGED_CASE, DIVERGED_CASE]
    assert all("step 7" in result.message for result in outcome.results.values())
    error = DivergenceError("x", step=1, time_s=0.0)
    assert (Diverged(error).diverged, Diverged(error).error, Diverged(error).result, Diverged(error).runs) \
        == (True, error, None, ())
    assert (Concluded(1).diverged, Concluded(1).error, Concluded(1).result) == (False, None, 1)


def test_a_sweep_composes_with_any_study_type_by_one_rule(tmp_path):
    """With [sweep], each case is a study of the type the study is without it: single studies make a
    ``SweepStudy``; any type that makes cases of its own is a ``NestedSweep`` of it, with what a sweep
    of that type writes (``SWEPT``); every such type has its entry."""
    from workflows.probabilistic.study_type import ProbabilisticStudy
    from workflows.refinement.study_type import RefinementStudy
    from workflows.single import SingleStudy
    from workflows.study_types import STUDY_TYPES, SWEPT, study_type
    from workflows.sweep.nested import NestedSweep
    from workflows.sweep.study_type import SweepStudy

    assert set(SWEPT) == {ProbabilisticStudy, RefinementStudy} and set(SWEPT) <= set(STUDY_TYPES) - {SingleStudy}
    sweep = '\n[sweep]\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [10e3, 14e3]\n'
    assert isinstance(study_type(parse_study(QUICKSTART + sweep), tmp_path), SweepStudy)
    refined = study_type(parse_study(QUICKSTART + "\n[refinement]\nspacings_m = [2.0, 1.68, 1.41, 1.19]\n" + sweep),
                         tmp_path)
    probabilistic = study_type(parse_study(
        QUICKSTART + '\n[probabilistic]\nrealisations = 4\n\n[[probabilistic.variables]]\n'
        'path = "materials.soil.friction_deg"\ndistribution = "normal"\nstd = 1.0\n' + sweep), tmp_path)
    for kind, inner in ((refined, RefinementStudy), (probabilistic, ProbabilisticStudy)):
        assert isinstance(kind, NestedSweep) and kind.summary is SWEPT[inner]
        assert all(type(each) is inner for each in kind.studies.values()) and len(kind.studies) == 2
    assert (refined.label, probabilistic.label) == ("a sweep of refinement studies", "a sweep of probabilistic studies")
    assert refined.placement.rounds and refined.placement.keep_going and not refined.placement.gravity_in_process


def test_every_field_declares_its_kind_as_one_object_that_checks_parses_and_shows_it():
    """``Spec.kind`` is an object of ``FIELD_KINDS`` (no field's kind is a string to compare); each value
    kind parses a value, refuses a wrong one with the line it always gave, and names itself in the
    reference."""
    from workflows.fields import FIELD_KINDS, NUMBER, POLYLINE, Spec, specs
    from workflows.study.tables import Study

    def every_spec(cls):
        for spec in specs(cls).values():
            yield spec
            for inner in (spec.variants.values() or [spec.of]) if spec.of is not None else []:
                yield from every_spec(inner)

    assert all(spec.kind in FIELD_KINDS.values() for spec in every_spec(Study))
    assert NUMBER.parse(Spec(NUMBER, gt=0.0), 2) == 2.0
    with pytest.raises(ValueError, match=r"^must be > 0, got -1$"):
        NUMBER.parse(Spec(NUMBER, gt=0.0), -1)
    with pytest.raises(ValueError, match="^x must increase from point to point"):
        POLYLINE.parse(Spec(POLYLINE), [[0.0, 0.0], [0.0, 1.0]])
    assert (NUMBER.shown, POLYLINE.shown, POLYLINE.allowed(Spec(POLYLINE))) == (
        "float", "`[[x, y], ...]` or file", ">= 2 points, x increasing")


def test_every_flow_rule_is_one_object_of_its_registry():
    """``flow_rule`` names an object of ``FLOW_RULES``, which tells the core's strength reduction whether
    the dilation follows the reduced friction; a name outside it is refused with the line it always gave."""
    from workflows.stages.flow_rules import FLOW_RULES

    class Table:
        def with_strength_reduction(self, srf, associated=False):
            return srf, associated

    assert list(FLOW_RULES) == ["associated", "as_declared"]
    stage = parse_study(QUICKSTART).strength_reduction
    assert stage.dilation_rule is FLOW_RULES["associated"] and stage.reduced(Table(), 1.5) == (1.5, True)
    declared = parse_study(QUICKSTART.replace("srf_step = 0.1", 'srf_step = 0.1\nflow_rule = "as_declared"'))
    assert declared.strength_reduction.reduced(Table(), 1.5) == (1.5, False)
    assert refusal(QUICKSTART.replace("srf_step = 0.1", 'srf_step = 0.1\nflow_rule = "normal"')) == (
        'stages[1].flow_rule: must be one of "associated", "as_declared", got "normal"')


PROBABILISTIC = ('\n[probabilistic]\nrealisations = 4\nmethod = "{method}"\ncompute = "{compute}"\n\n'
                 '[[probabilistic.variables]]\npath = "materials.soil.friction_deg"\ndistribution = "normal"\n'
                 'std = 1.0\n')


def test_a_probabilistic_method_is_one_object_mapped_to_the_study_type_that_plans_its_rounds(tmp_path):
    """``method`` names an object of ``METHODS`` (its checks, its draw) and ``compute`` one of
    ``COMPUTATIONS``; every method has the study type that plans its rounds, which ``study_type`` picks."""
    from workflows.probabilistic.form_study import FormStudy
    from workflows.probabilistic.kinds import COMPUTATIONS, METHODS
    from workflows.probabilistic.point_estimate_study import PointEstimateStudy
    from workflows.probabilistic.study_type import ProbabilisticStudy
    from workflows.probabilistic.subset_study import SubsetStudy
    from workflows.study_types import METHOD_STUDY_TYPES, study_type

    assert set(METHOD_STUDY_TYPES) == set(METHODS.values())
    expected = {"monte_carlo": ProbabilisticStudy, "latin_hypercube": ProbabilisticStudy, "form": FormStudy,
                "point_estimate": PointEstimateStudy, "subset_simulation": SubsetStudy}
    for name, kind in expected.items():
        text = QUICKSTART + PROBABILISTIC.format(method=name, compute="fos")
        if name == "subset_simulation":
            text = text.replace("realisations = 4", "realisations = 600")
        study = parse_study(text)
        assert study.probabilistic.method_kind is METHODS[name]
        assert study.probabilistic.computation is COMPUTATIONS["fos"]
        assert type(study_type(study, tmp_path)) is kind

    class Sampler:
        def monte_carlo(self, seed, indices):
            return "monte_carlo", seed, list(indices)

        def latin_hypercube(self, seed, count):
            return "latin_hypercube", seed, count

    assert METHODS["monte_carlo"].draw(Sampler(), 7, 3) == ("monte_carlo", 7, [0, 1, 2])
    assert METHODS["latin_hypercube"].draw(Sampler(), 7, 3) == ("latin_hypercube", 7, 3)
    assert [method.placed for method in METHODS.values()] == [False, False, True, True, True]
    assert [c.searches for c in COMPUTATIONS.values()] == [False, True]
    assert refusal(QUICKSTART + PROBABILISTIC.format(method="form", compute="verdict")) == (
        'probabilistic.compute: form takes the FOS of each point: give compute = "fos"')
    assert refusal(QUICKSTART + PROBABILISTIC.format(method="point_estimate", compute="fos").replace(
        "realisations = 4", "realisations = 1")) == (
        "probabilistic.realisations: point_estimate with 1 variables needs at least 2 FOS searches (2^n points), got 1")


def test_a_nested_table_is_a_field_kind_that_the_reader_and_the_reference_visit():
    """``FieldKind.visit`` sends a value, one nested table and an array of tables each to its own method of
    the visitor (the study reader and the reference walk the tables so, never comparing kinds)."""
    from workflows.fields import FIELD_KINDS, Spec

    class Visitor:
        value = staticmethod(lambda spec, extra: ("value", extra))
        table = staticmethod(lambda spec, extra: ("table", extra))
        tables = staticmethod(lambda spec, extra: ("tables", extra))

    visited = {name: kind.visit(Visitor, Spec(kind), 1) for name, kind in FIELD_KINDS.items()}
    assert visited.pop("table") == ("table", 1) and visited.pop("tables") == ("tables", 1)
    assert set(visited.values()) == {("value", 1)}
