"""Random fields of soil properties in a study file (``[random_field]``): the particles' values have
the target statistics after local averaging, cross-correlation and anisotropy are honoured, a
realisation depends only on its seed and number, random strengths share one gravity state, and bad
tables name their field."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from workflows.cases import RunOptions
from workflows.distributions import LOGNORMAL, NORMAL, lognormal_parameters
from workflows.fos.keys import gravity_key, run_key
from workflows.probabilistic.study_type import realisation_cases
from workflows.random_field.correlation import MARKOV
from workflows.random_field.embedding import cell_correlation, variance_function
from workflows.scene import build_scene
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()
COHESION_FIELD = ('name = "c"\nmaterial = "soil"\nproperty = "cohesion_pa"\ndistribution = "lognormal"\n'
                  'cov = 0.5\ntheta_x_m = 4.0\n')


def with_fields(*entries: str, seed: int = 1, realisation: int = 0) -> str:
    text = QUICKSTART + f"\n[random_field]\nseed = {seed}\nrealisation = {realisation}\n"
    return text + "".join(f"\n[[random_field.properties]]\n{entry}" for entry in entries)


def values(text: str, name: str = "cohesion_pa") -> tuple[np.ndarray, object]:
    scene = build_scene(parse_study(text))
    return scene.node_properties[name], scene


def test_a_lognormal_field_has_the_log_mean_and_the_cell_averaged_log_variance_of_its_target():
    """ln c at the particles over 100 realisations: mean mu_ln, variance sigma_ln^2 gamma(h, h) (the
    variance reduction of a cell average), within 3 standard errors of a correlated sample."""
    draws = np.array([np.log(values(with_fields(COHESION_FIELD, realisation=r))[0]) for r in range(100)])
    study = parse_study(with_fields(COHESION_FIELD))
    h = study.geometry.spacing_m
    mu, sigma = lognormal_parameters(10e3, 0.5)
    target_variance = sigma**2 * variance_function(MARKOV, h, h, 4.0, 4.0)
    assert draws.mean() == pytest.approx(mu, abs=3 * math.sqrt(target_variance / 100))  # realisation means
    assert draws.var(axis=0).mean() == pytest.approx(target_variance, rel=0.05)
    assert target_variance < 0.9 * sigma**2  # the averaging matters at this h / theta


def test_anisotropic_scales_of_fluctuation_give_the_markov_correlation_along_each_axis():
    """theta_x = 20 m, theta_y = 2 m: particle pairs 2 m apart correlate along each axis as the
    averages of their cells do (``cell_correlation``: 0.90 horizontally, 0.19 vertically at h = 1 m;
    the points' exp(-2 tau / theta) would be 0.82 and 0.14)."""
    entry = COHESION_FIELD.replace("theta_x_m = 4.0", "theta_x_m = 20.0\ntheta_y_m = 2.0").replace(
        "lognormal", "normal").replace("cov = 0.5", "cov = 0.1")
    scene = build_scene(parse_study(with_fields(entry)))
    xy = scene.node_xy_m
    lookup = {(round(x, 6), round(y, 6)): k for k, (x, y) in enumerate(xy)}
    pairs = {axis: [(k, lookup[key]) for k, (x, y) in enumerate(xy)
                    if (key := (round(x + 2.0 * (axis == 0), 6), round(y + 2.0 * (axis == 1), 6))) in lookup]
             for axis in (0, 1)}
    draws = np.array([values(with_fields(entry, realisation=r))[0] for r in range(60)])
    standard = (draws - draws.mean(axis=0)) / draws.std(axis=0)
    h = parse_study(QUICKSTART).geometry.spacing_m
    for axis in (0, 1):
        a, b = np.array(pairs[axis]).T
        rho = float(np.mean(standard[:, a] * standard[:, b]))
        lag = (2.0 * (axis == 0), 2.0 * (axis == 1))
        assert rho == pytest.approx(cell_correlation(MARKOV, h, *lag, 20.0, 2.0), abs=0.05)


def test_two_fields_of_one_material_correlate_by_their_coefficient():
    """c and phi, normal, correlated -0.6: the particle values correlate by -0.6."""
    phi = ('name = "phi"\nmaterial = "soil"\nproperty = "friction_deg"\ndistribution = "normal"\nstd = 2.0\n'
           'theta_x_m = 4.0\ncorrelated_with = "c"\ncorrelation = -0.6\n')
    c = COHESION_FIELD.replace("lognormal", "normal").replace("cov = 0.5", "cov = 0.2")
    pooled = []
    for r in range(20):
        scene = build_scene(parse_study(with_fields(c, phi, realisation=r)))
        pooled.append(np.column_stack([scene.node_properties["cohesion_pa"], scene.node_properties["friction_deg"]]))
    pooled = np.concatenate(pooled)
    assert np.corrcoef(pooled.T)[0, 1] == pytest.approx(-0.6, abs=0.03)
    assert pooled[:, 1].mean() == pytest.approx(20.0, abs=0.3)


def test_a_realisation_depends_on_its_seed_and_number_only():
    """The same seed and number give the same field, another number another; adding a second field
    does not change the first."""
    first, _ = values(with_fields(COHESION_FIELD, realisation=3))
    again, _ = values(with_fields(COHESION_FIELD, realisation=3))
    other, _ = values(with_fields(COHESION_FIELD, realisation=4))
    stiffness = ('name = "E"\nmaterial = "soil"\nproperty = "youngs_modulus_pa"\ndistribution = "lognormal"\n'
                 'cov = 0.3\ntheta_x_m = 8.0\n')
    beside, scene = values(with_fields(stiffness, COHESION_FIELD, realisation=3))
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(first, beside)
    assert not np.allclose(first, other)
    assert "youngs_modulus_pa" in scene.node_properties


def test_realisations_of_random_strengths_share_one_gravity_state_and_a_random_stiffness_does_not():
    probabilistic = "\n[probabilistic]\nrealisations = 4\n"
    strengths = parse_study(with_fields(COHESION_FIELD) + probabilistic)
    cases = realisation_cases(strengths)
    assert len({gravity_key(case.study) for case in cases}) == 1
    assert len({run_key(case.study, 1.0) for case in cases}) == 4
    stiffness = COHESION_FIELD.replace("cohesion_pa", "youngs_modulus_pa")
    assert len({gravity_key(case.study) for case in realisation_cases(parse_study(with_fields(stiffness) + probabilistic))}) == 4


@pytest.mark.parametrize("entry, field, message", [
    (COHESION_FIELD.replace('material = "soil"', 'material = "rock"'), "random_field.properties[0].material",
     "no material named"),
    (COHESION_FIELD.replace("cohesion_pa", "undrained_shear_strength_pa"), "random_field.properties[0].property",
     "no property of"),
    (COHESION_FIELD.replace("cohesion_pa", "cohesion_kpa"), "random_field.properties[0].property",
     "names the property in SI units, 'cohesion_pa'"),
    (COHESION_FIELD.replace("lognormal", "normal"), "random_field.properties[0].distribution", "lognormal"),
    (COHESION_FIELD + 'correlated_with = "phi"\ncorrelation = 0.5\n', "random_field.properties[0].correlated_with",
     "another field"),
    (COHESION_FIELD.replace("cov = 0.5", "cov = 0.5\nstd = 1e3"), "random_field.properties[0].std", "one of them"),
])
def test_bad_random_fields_name_the_field(entry, field, message):
    with pytest.raises(StudyError) as error:
        parse_study(with_fields(entry))
    assert error.value.field == field and message in str(error.value)


def test_cross_correlated_fields_must_share_their_correlation_structure():
    phi = ('name = "phi"\nmaterial = "soil"\nproperty = "friction_deg"\ndistribution = "normal"\nstd = 2.0\n'
           'theta_x_m = 8.0\ncorrelated_with = "c"\ncorrelation = -0.5\n')
    with pytest.raises(StudyError) as error:
        parse_study(with_fields(COHESION_FIELD, phi))
    assert error.value.field == "random_field.properties[1].correlated_with" and "structure" in str(error.value)


def test_a_probabilistic_study_of_a_random_field_alone_runs_and_reuses_its_realisations(tmp_path):
    """A cohesion field alone ([probabilistic] without variables), 3 realisations at F = 1.3: each a
    run of its own field on one shared gravity state (one file, OUT/gravity/), the result in
    probabilistic.nc; the failed realisations' run files keep the particle state, the stable ones'
    only their histories; rerun, nothing is computed again."""
    text = with_fields(COHESION_FIELD) + "\n[probabilistic]\nrealisations = 3\nfactor = 1.3\n"
    first = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert first.runs_made == 3 and first.n_undecided == 0 and 0 < first.n_failed < 3  # both kinds of file
    assert not list((tmp_path / "cases").glob("*/gravity*.nc"))
    assert [path.name for path in (tmp_path / "gravity").glob("*.nc")] == ["gravity.nc"]  # relaxed once
    for run_file in (tmp_path / "cases").glob("*/srf_*.nc"):
        with xr.open_dataset(run_file) as run:
            assert ("particle_x" in run) == (run.attrs["status"] == "failed") == bool(run.attrs["particle_fields"])
            assert "max_displacement" in run and run.sizes["time"] > 1
    ds = xr.load_dataset(tmp_path / "probabilistic.nc")
    assert ds.sizes["realisation"] == 3
    assert len(list(tmp_path.glob("failed_realisation_*.png"))) == min(3, first.n_failed)
    again = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert again.runs_made == 0 and again.pf == first.pf


@pytest.mark.parametrize("theta_m, method", [(100.0, "expansion"), (1000.0, "expansion"), (1e5, "single")])
def test_a_scale_of_fluctuation_no_embedding_holds_is_drawn_another_way_with_a_note(theta_m, method, tmp_path):
    """theta 100 m on the 60 m section, or 1,000 m: a ValueError traceback from the embedding in check and
    the run before, then a refusal naming the longest scale the section held; now the Karhunen-Loeve
    expansion, with a note of the variance it keeps in check, and beyond 100 times the section one value per
    realisation (the single-variable limit), with its note."""
    from workflows.check import check_study
    from workflows.study_types import study_type

    text = with_fields(COHESION_FIELD.replace("theta_x_m = 4.0", f"theta_x_m = {theta_m}")) + (
        "\n[probabilistic]\nrealisations = 3\n")
    study = parse_study(text)
    lines = check_study(study, study_type(study, tmp_path), tmp_path, RunOptions()).lines()
    notes = [line for line in lines if line.startswith("note: random field 'c'")]
    assert len(notes) == 1, lines
    if method == "expansion":
        kept = float(notes[0].split("keeps ")[1].split("%")[0])
        assert "Karhunen-Loeve" in notes[0] and 99.0 < kept <= 100.0
    else:
        assert "single-variable limit" in notes[0]
    cohesion, scene = values(text)
    soil = np.isfinite(cohesion)
    assert soil.all() and (method == "single") == (np.ptp(cohesion) == 0.0)
    assert not np.array_equal(cohesion, values(text.replace("realisation = 0", "realisation = 1"))[0])


DILATION_FIELD = ('name = "psi"\nmaterial = "soil"\nproperty = "dilation_deg"\ndistribution = "lognormal"\n'
                  'mean = 10.0\ncov = 0.5\ntheta_x_m = 4.0\n')
FRICTION_FIELD = ('name = "phi"\nmaterial = "soil"\nproperty = "friction_deg"\ndistribution = "normal"\n'
                  'std = 3.0\ntheta_x_m = 4.0\n')


@pytest.mark.parametrize("entries, field, probability", [
    # psi lognormal (10, 5) against phi 20: P(ln psi > ln 20)
    ((DILATION_FIELD,), "random_field.properties[0].distribution",
     0.5 * math.erfc((math.log(20.0) - lognormal_parameters(10.0, 0.5)[0]) / lognormal_parameters(10.0, 0.5)[1]
                     / math.sqrt(2.0))),
    # phi normal (20, 3) below a dilation of 15: P(phi < 15)
    ((FRICTION_FIELD,), "random_field.properties[0].distribution", 0.5 * math.erfc(5.0 / 3.0 / math.sqrt(2.0))),
])
def test_a_field_that_breaks_dilation_at_most_friction_is_refused_with_its_probability(entries, field, probability,
                                                                                       tmp_path):
    """A dilation field that exceeds the friction angle at some particles (or a friction field below a
    fixed dilation): check passed it and the run ended in MaterialTable's ValueError with case folders
    written; now check and the run refuse it alike, naming the field and the probability at a point."""
    text = with_fields(*entries)
    if entries == (FRICTION_FIELD,):
        text = text.replace("dilation_deg = 0.0", "dilation_deg = 15.0")
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == field and "dilation_deg exceeds its friction_deg" in error.value.problem
    stated = float(error.value.problem.split("with probability ")[1].split(" ")[0])
    assert stated == pytest.approx(probability, rel=0.01)


def test_the_order_probability_of_two_correlated_fields_is_their_joint_law():
    """P(psi > phi) for correlated normal, lognormal and mixed pairs against 400,000 correlated draws."""
    from workflows.random_field.table import order_broken_probability

    rng = np.random.default_rng(0)
    rho = 0.6
    g_u = rng.standard_normal(400_000)
    g_l = rho * g_u + math.sqrt(1.0 - rho * rho) * rng.standard_normal(g_u.size)
    mu, sigma = lognormal_parameters(10.0, 0.5)
    for lower, upper, x_l, x_u in (
            ((NORMAL, 10.0, 5.0), (NORMAL, 18.0, 4.0), 10.0 + 5.0 * g_l, 18.0 + 4.0 * g_u),
            ((LOGNORMAL, 10.0, 5.0), (NORMAL, 20.0, 4.0), np.exp(mu + sigma * g_l), 20.0 + 4.0 * g_u)):
        expected = float(np.mean(x_l > x_u))
        assert order_broken_probability(lower, upper, rho) == pytest.approx(expected, abs=4e-4)


def test_the_rare_particles_whose_dilation_would_exceed_their_friction_take_their_friction():
    """Below the refusal's probability, a particle whose fields break psi <= phi gets psi = phi, the
    others keep their own values (here a friction field with values below the material's dilation at
    a few particles)."""
    from workflows.random_field.values import keep_order

    study = parse_study(QUICKSTART.replace("dilation_deg = 0.0", "dilation_deg = 5.0"))
    node_material = np.zeros(6, dtype=np.int64)
    out = {"friction_deg": np.array([20.0, 4.0, 30.0, 5.0, 2.0, 25.0])}
    keep_order(study.materials, node_material, out)
    np.testing.assert_array_equal(out["dilation_deg"], [np.nan, 4.0, np.nan, np.nan, 2.0, np.nan])
