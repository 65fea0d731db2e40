"""FORM (Hasofer-Lind / Rackwitz-Fiessler on a limit state, through the project's Nataf transform) and the
point estimate method against closed forms; a form or point_estimate study's table refusals; and a
FORM study end to end (slow): beta beside the FOSM index, resumed without a run."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from workflows.distributions import LOGNORMAL, NORMAL
from workflows.probabilistic import form, point_estimate
from workflows.probabilistic.sampling import Marginal, Sampler
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]


def _form(g, sampler: Sampler, step: float = 0.05, tolerance: float = 1e-6, iterations: int = 30):
    """FORM's iterations as the study makes them (design_points.DesignPointStudy.next_cases), on g(x)."""
    n = len(sampler.marginals)
    centre, betas, linearisation = np.zeros(n), [], None
    for _ in range(iterations):
        u = form.gradient_points(centre, step)
        x = sampler._values(u @ sampler.cholesky.T)
        linearisation = form.Linearisation.of(centre, np.array([g(row) for row in x]), step)
        betas.append(linearisation.beta)
        if form.converged(betas, tolerance):
            break
        centre = linearisation.next_u
    return linearisation, betas


def test_form_on_a_linear_limit_state_of_normals_is_the_exact_index_at_once():
    """g = x1 + 2 x2 - 14, x1 ~ N(5, 1), x2 ~ N(6, 0.5): beta = (5 + 12 - 14) / sqrt(1 + 1) exactly, the
    first iteration (FOSM) already; alpha the normalised gradient in u."""
    sampler = Sampler([Marginal(NORMAL, 5.0, 1.0), Marginal(NORMAL, 6.0, 0.5)])
    linearisation, betas = _form(lambda x: x[0] + 2.0 * x[1] - 14.0, sampler)
    assert betas[0] == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-9)
    assert linearisation.beta == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-9)
    assert linearisation.alpha == pytest.approx(np.array([1.0, 1.0]) / math.sqrt(2.0))


def test_form_through_the_nataf_transform_of_two_lognormals_finds_the_exact_index():
    """g = R - S, R and S lognormal (means 10 and 5, COVs 0.2 and 0.3): the limit state ln R = ln S is a
    plane in u, beta = (mu_lnR - mu_lnS) / sqrt(s_lnR^2 + s_lnS^2); FORM on the nonlinear g finds it (to the
    forward difference's step), where the mean-value FOSM index does not."""
    marginals = [Marginal(LOGNORMAL, 10.0, 2.0), Marginal(LOGNORMAL, 5.0, 1.5)]
    ln = [(math.log(m.mean) - 0.5 * math.log1p((m.std / m.mean) ** 2), math.sqrt(math.log1p((m.std / m.mean) ** 2)))
          for m in marginals]
    exact = (ln[0][0] - ln[1][0]) / math.hypot(ln[0][1], ln[1][1])
    linearisation, betas = _form(lambda x: x[0] - x[1], Sampler(marginals), step=1e-4)
    assert linearisation.beta == pytest.approx(exact, rel=1e-3)
    assert abs(betas[0] - exact) > 0.05  # FOSM at the mean: another number
    assert form.failure_probability(exact) == pytest.approx(0.5 * math.erfc(exact / math.sqrt(2.0)))


def test_form_agrees_with_openturns_on_correlated_non_normal_variables():
    """A nonlinear g of a lognormal and a correlated normal (rho = 0.4): beta and the design point as
    OpenTURNS' FORM (its Nataf transform, Abdo-Rackwitz) finds them, within 1e-3."""
    ot = pytest.importorskip("openturns")
    marginals = [Marginal(LOGNORMAL, 20.0, 4.0), Marginal(NORMAL, 30.0, 3.0)]
    correlation = np.array([[1.0, 0.4], [0.4, 1.0]])

    def g(x):
        return 0.1 * x[0] * x[1] ** 0.5 - 6.0

    linearisation, _ = _form(g, Sampler(marginals, correlation), step=1e-4, tolerance=1e-8)
    sampler = Sampler(marginals, correlation)
    ln_sigma = math.sqrt(math.log1p(0.04))
    distribution = ot.JointDistribution(
        [ot.LogNormal(math.log(20.0) - 0.5 * ln_sigma**2, ln_sigma), ot.Normal(30.0, 3.0)],
        ot.NormalCopula(ot.CorrelationMatrix(2, [1.0, sampler.normal[0, 1], sampler.normal[0, 1], 1.0])))
    model = ot.PythonFunction(2, 1, lambda x: [g(x)])
    event = ot.ThresholdEvent(ot.CompositeRandomVector(model, ot.RandomVector(distribution)), ot.Less(), 0.0)
    algorithm = ot.FORM(ot.AbdoRackwitz(), event, distribution.getMean())
    algorithm.run()
    result = algorithm.getResult()
    assert linearisation.beta == pytest.approx(result.getHasoferReliabilityIndex(), abs=1e-3)
    design = sampler._values((linearisation.next_u @ sampler.cholesky.T)[None, :])[0]
    assert design == pytest.approx(np.array(result.getPhysicalSpaceDesignPoint()), rel=1e-3)


def test_a_step_within_the_noise_names_its_variable():
    fos = np.array([1.30, 1.31, 1.302])
    assert form.noisy_variables(fos, np.full(3, 0.002), 3.0) == [1]


def test_the_point_estimate_of_a_linear_fos_is_exact_with_correlation():
    """F = 1 + 0.02 c + 0.01 phi with correlated normal c and phi: Rosenblueth's 4 points give the mean and
    the std of the linear function exactly (weights (1 + s_c s_phi rho) / 4)."""
    means, stds, rho = np.array([10.0, 20.0]), np.array([3.0, 2.0]), -0.5
    weights = point_estimate.weights(np.array([[1.0, rho], [rho, 1.0]]))
    assert weights.sum() == pytest.approx(1.0)
    x = point_estimate.points(means, stds)
    mean, std = point_estimate.moments(1.0 + 0.02 * x[:, 0] + 0.01 * x[:, 1], weights)
    assert mean == pytest.approx(1.0 + 0.2 + 0.2)
    assert std == pytest.approx(math.sqrt(0.06**2 + 0.02**2 + 2 * rho * 0.06 * 0.02))
    beta_n, beta_ln = point_estimate.reliability_indices(1.4, 0.2, 1.0)
    assert beta_n == pytest.approx(2.0)
    assert beta_ln == pytest.approx(math.log(1.4 / math.sqrt(1 + (0.2 / 1.4) ** 2)) / math.sqrt(math.log1p((0.2 / 1.4) ** 2)))


C_PHI = (REPO / "studies" / "probabilistic_c_phi.toml").read_text()


def _method(text: str, method: str, realisations: int = 40, compute: str = "fos") -> str:
    return (text.replace('method = "latin_hypercube"', f'method = "{method}"')
            .replace("realisations = 40", f"realisations = {realisations}")
            .replace('compute = "fos"', f'compute = "{compute}"'))


@pytest.mark.parametrize("method, realisations, compute, field", [
    ("form", 40, "verdict", "probabilistic.compute"),
    ("form", 5, "fos", "probabilistic.realisations"),
    ("point_estimate", 3, "fos", "probabilistic.realisations"),
])
def test_a_form_or_point_estimate_study_that_cannot_run_is_one_line(method, realisations, compute, field):
    with pytest.raises(StudyError) as error:
        parse_study(_method(C_PHI, method, realisations, compute))
    assert error.value.field == field


def test_form_with_a_random_field_is_refused_naming_the_method():
    text = _method(C_PHI, "form") + ('\n[random_field]\n[[random_field.properties]]\nname = "c"\nmaterial = "soil"\n'
                                     'property = "friction_deg"\ndistribution = "normal"\nstd = 1.0\ntheta_x_m = 5.0\n')
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == "probabilistic.method"


@pytest.mark.parametrize("method", ["form", "subset_simulation", "point_estimate"])
def test_every_point_is_searched_from_half_the_factor_to_twice_it(method):
    """A factor of 5 over a search to srf_max = 2: FORM's points near its design point (FOS = 5) lay above
    every search (beta -29, "NOT converged"), and subset simulation counted a FOS above srf_max as never below
    the factor (pf too low).  Each point's range now holds [factor / 2, 2 factor]; the stage's own when wider."""
    from workflows.probabilistic.design_points import DesignPoints

    text = _method(C_PHI, method, 100).replace("factor = 1.0", "factor = 5.0")
    if method == "subset_simulation":
        text = text.replace("realisations = 100", "realisations = 100\nsamples_per_level = 50")
    stage = DesignPoints(parse_study(text)).raw["stages"][1]
    assert (stage["srf_min"], stage["srf_max"]) == (1.0, 10.0)
    stage = DesignPoints(parse_study(_method(C_PHI, method, 100).replace("realisations = 100", "realisations = 100"
                         + ("\nsamples_per_level = 50" if method == "subset_simulation" else "")))).raw["stages"][1]
    assert (stage["srf_min"], stage["srf_max"]) == (0.5, 2.0)


@pytest.mark.slow
def test_a_form_study_gives_beta_beside_fosm_and_resumes_without_a_run(tmp_path):
    """The c-phi slope (lognormal c, truncated normal phi, correlated -0.5), FORM at h = 1 m: converged, the
    design point's FOS near the factor, beta above the FOSM index (the lognormal c's tail), pf_FORM =
    Phi(-beta); run again, every point's runs read back (none made) and the same beta."""
    import xarray as xr

    from workflows.cases import RunOptions
    from workflows.study_types import run_study

    study = parse_study(_method(C_PHI, "form"))
    first = run_study(study, tmp_path, RunOptions(workers=2))
    assert first.converged and first.n_searches % 3 == 0 and 2.0 < first.beta < 5.0
    ds = xr.load_dataset(tmp_path / "probabilistic.nc")
    centres = ds["fos"].values[::3]
    assert abs(centres[-1] - 1.0) < 0.05
    assert ds.attrs["pf_form"] == pytest.approx(form.failure_probability(first.beta))
    assert math.isnan(ds.attrs["pf"]) and (tmp_path / "form.png").exists()
    again = run_study(study, tmp_path, RunOptions(workers=2))
    assert again.runs_made == 0 and again.beta == first.beta


def _subset_study(tmp_path, seed: int, samples: int = 200):
    """A subset simulation of the c-phi slope with one normal cohesion (mean 10 kPa, std 1 kPa), its FOS
    replaced by c / 7 kPa (the study's points and levels, no run): pf = P(c < 7 kPa) = Phi(-3)."""
    from workflows.cases import RunOptions
    from workflows.study_types import study_type

    text = C_PHI[: C_PHI.index("[probabilistic]")] + (
        f'[probabilistic]\nmethod = "subset_simulation"\nrealisations = 5000\nsamples_per_level = {samples}\n'
        f'seed = {seed}\ncompute = "fos"\nfactor = 1.0\n\n[[probabilistic.variables]]\n'
        'path = "materials.soil.cohesion_pa"\ndistribution = "normal"\nstd = 1000.0\n')
    kind = study_type(parse_study(text), tmp_path / f"seed_{seed}")
    kind.check(RunOptions(workers=1))
    kind.cases()
    return kind


def _fake_outcome(fos: float):
    """A concluded case (``cases.Concluded``) whose search found ``fos``."""
    from types import SimpleNamespace

    from workflows.cases import Concluded

    return Concluded(SimpleNamespace(runs=[], fos=fos, fos_low=fos - 1e-3, fos_high=fos + 1e-3, criteria_agree=True,
                           knee_srf=math.nan, n_particles=0, verdict="", status_low=math.nan,
                                     status_high=math.nan))


def test_subset_simulation_levels_reach_a_small_pf_within_their_interval(tmp_path):
    """pf = Phi(-3) = 1.35e-3 by the study's own levels and chains (FOS c / 7 kPa, 200 points a level), over
    three seeds: each estimate's approximate 95% interval holds the exact value, with 3 or 4 levels and under
    1,000 FOS searches where crude Monte Carlo needs (1 - pf) / (pf cov^2) for the same cov; with every FOS
    lowered by the expected discretisation excess (the slope's phi = 20 deg), pf from the last level rises."""
    from workflows.probabilistic.subset_study import SubsetStudy
    from workflows.progress import Progress

    exact = 0.5 * math.erfc(3.0 / math.sqrt(2.0))
    for seed in (1, 2, 3):
        kind = _subset_study(tmp_path, seed)
        assert isinstance(kind, SubsetStudy)
        points, outcomes, progress = kind.realisations, {}, Progress()
        while True:
            for i in range(len(outcomes), points.count):
                outcomes[points.case_id(i)] = _fake_outcome(points.values[i, 0] / 7e3)
            if not kind.next_cases(outcomes, progress) and kind.finished:
                break
        levels = kind.levels
        assert levels[-1]["last"] and len(levels) in (3, 4) and not kind.stop_reason
        p = 0.1 ** (len(levels) - 1) * levels[-1]["fraction"]
        from workflows.probabilistic import subset

        cov = math.sqrt(sum(subset.level_cov(level["fraction"], 200, level["gamma"]) ** 2 for level in levels))
        low, high = subset.interval(p, cov)
        assert low <= exact <= high, (seed, p, cov)
        assert 0.15 < cov < 0.8 and points.count < 1000
        assert (1 - p) / (p * cov**2) > 2 * points.count
        excess_low, excess_high, pf_low, pf_high = kind._discretisation(None)  # FOS lowered by the expected excess
        assert 0.0 < excess_low < excess_high and p <= pf_low <= pf_high
        exact_high = 0.5 * math.erfc((10e3 - 7e3 * (1 + excess_high)) / 1e3 / math.sqrt(2.0))
        assert pf_high > 0.5 * exact_high if exact_high > 2 * exact else True


def test_subset_seeds_and_threshold_and_the_chains_correlation():
    fos = np.array([1.5, 1.1, 1.3, 0.9, 1.2, 1.4, 1.6, 1.7, 1.8, 1.9])
    order, threshold, last = subset_module().seeds_and_threshold(fos, 0.2, 0.8)
    assert list(order) == [3, 1] and threshold == pytest.approx(1.15) and not last
    assert subset_module().seeds_and_threshold(fos, 0.1, 1.0)[2]  # one of ten below the factor: the last level
    independent = np.random.default_rng(1).random((400, 10)) < 0.1
    assert subset_module().chain_gamma(independent) < 0.15
    stuck = np.repeat(np.random.default_rng(2).random((400, 1)) < 0.1, 10, axis=1)  # chains that never move
    assert subset_module().chain_gamma(stuck) == pytest.approx(9.0, rel=0.05)  # 2 sum (1 - l / 10) over 9 lags


def subset_module():
    from workflows.probabilistic import subset

    return subset
