"""FORM (Hasofer-Lind / Rackwitz-Fiessler on a limit state, through the project's Nataf transform) and the
point estimate method against closed forms; a form or point_estimate study's table refusals; and a
FORM study end to end (slow): beta beside the FOSM index, resumed without a run."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

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
    sampler = Sampler([Marginal("normal", 5.0, 1.0), Marginal("normal", 6.0, 0.5)])
    linearisation, betas = _form(lambda x: x[0] + 2.0 * x[1] - 14.0, sampler)
    assert betas[0] == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-9)
    assert linearisation.beta == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-9)
    assert linearisation.alpha == pytest.approx(np.array([1.0, 1.0]) / math.sqrt(2.0))


def test_form_through_the_nataf_transform_of_two_lognormals_finds_the_exact_index():
    """g = R - S, R and S lognormal (means 10 and 5, COVs 0.2 and 0.3): the limit state ln R = ln S is a
    plane in u, beta = (mu_lnR - mu_lnS) / sqrt(s_lnR^2 + s_lnS^2); FORM on the nonlinear g finds it (to the
    forward difference's step), where the mean-value FOSM index does not."""
    marginals = [Marginal("lognormal", 10.0, 2.0), Marginal("lognormal", 5.0, 1.5)]
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
    marginals = [Marginal("lognormal", 20.0, 4.0), Marginal("normal", 30.0, 3.0)]
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
