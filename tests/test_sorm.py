"""SORM (``workflows.probabilistic.sorm``): the curvatures of sampled limit states and Breitung's and
Hohenbichler-Rackwitz's pf against the exact pf of paraboloids, a linear limit state (SORM == FORM), a
rotated paraboloid found by FORM's own iteration; and a form study's SORM round on a scripted FOS (no run)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, stats

from workflows.probabilistic import form, sorm
from workflows.probabilistic.kinds import sorm_searches
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]


def _paraboloid_pf(beta: float, ks) -> float:
    """The exact pf of g = beta - u_n + sum k_i / 2 u_i^2: P(u_n > beta + sum k_i / 2 u_i^2) = E[Phi(-(beta +
    sum k_i / 2 u_i^2))], by quadrature (one k) or over 2,000,000 tangential normals (a conditional Monte
    Carlo: its relative error about 1e-3)."""
    ks = np.asarray(ks, float)
    if ks.size == 1:
        return integrate.quad(lambda x: stats.norm.sf(beta + 0.5 * ks[0] * x * x) * stats.norm.pdf(x),
                              -np.inf, np.inf, epsabs=0.0, epsrel=1e-12)[0]
    u = np.random.default_rng(7).standard_normal((2_000_000, ks.size))
    return float(np.mean(stats.norm.sf(beta + 0.5 * (u**2) @ ks)))


def _random_rotation(n: int, seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((n, n)))
    return q * np.sign(np.diag(r))


def _sampled(g, design_u, step=0.5, half_brackets=None) -> sorm.Curvatures:
    points = sorm.curvature_points(design_u, step)
    return sorm.Curvatures.of(design_u, np.array([g(u) for u in points]), step, half_brackets)


def test_the_rotation_is_orthogonal_with_the_design_point_on_its_last_axis():
    for design_u in (np.array([0.0, 0.0, 2.5]), np.array([1.0, -2.0, 0.5, 0.0]), np.array([0.0, 3.0])):
        rotation = sorm.rotation(design_u)
        assert rotation @ rotation.T == pytest.approx(np.eye(design_u.size), abs=1e-12)
        assert rotation @ design_u == pytest.approx(np.r_[np.zeros(design_u.size - 1), np.linalg.norm(design_u)])
    assert sorm_searches(4) == len(sorm.curvature_points(np.array([1.0, 1.0, 1.0, 1.0]), 0.5)) == 21
    assert sorm_searches(2) == len(sorm.curvature_points(np.array([1.0, 2.0]), 0.5)) == 5 and sorm_searches(1) == 0


def test_breitung_is_the_asymptote_of_the_exact_pf_of_a_paraboloid():
    """g = beta - u_2 + k / 2 u_1^2, k = 0.1: Breitung's pf / exact -> 1 as beta grows (errors falling), within
    3% at beta 3 where FORM's Phi(-beta) is 14% off; Hohenbichler-Rackwitz's closer still; a wrong exponent
    (-1 for -1/2) misses by 12% at beta 3."""
    errors = []
    for beta in (2.0, 3.0, 5.0, 8.0):
        exact = _paraboloid_pf(beta, [0.1])
        breitung = sorm.breitung(beta, np.array([0.1]))
        hr = sorm.hohenbichler_rackwitz(beta, np.array([0.1]))
        assert breitung is not None and hr is not None
        errors.append(abs(breitung / exact - 1.0))
        assert abs(hr / exact - 1.0) < errors[-1]
    assert errors == sorted(errors, reverse=True) and errors[1] < 0.03 and errors[-1] < 0.01
    exact = _paraboloid_pf(3.0, [0.1])
    assert abs(stats.norm.sf(3.0) / exact - 1.0) > 0.1
    assert abs(stats.norm.sf(3.0) / (1 + 3.0 * 0.1) / exact - 1.0) > 0.1


@pytest.mark.parametrize("beta, ks, within", [
    (3.0, [0.2, -0.1], 0.02), (5.0, [0.2, 0.3], 0.04), (2.5, [0.15, 0.05, -0.08], 0.03), (3.0, [-0.2], 0.01),
])
def test_curvatures_sampled_from_a_paraboloid_give_its_pf(beta, ks, within):
    """The curvatures from g sampled about u* (the step of a second difference: exact on a quadratic) are the
    paraboloid's k, and Breitung's pf is the exact one within a few per cent (2,000,000-sample conditional Monte
    Carlo or quadrature)."""
    n = len(ks) + 1
    ks = np.array(ks)

    def g(u):
        return beta - u[-1] + 0.5 * ks @ u[:-1] ** 2

    shape = _sampled(g, np.r_[np.zeros(n - 1), beta], step=0.7)
    assert shape.outward and shape.gradient_norm == pytest.approx(1.0)
    assert shape.kappas == pytest.approx(np.sort(ks), abs=1e-9)
    breitung = sorm.breitung(shape.beta, shape.kappas)
    assert breitung is not None
    assert breitung == pytest.approx(_paraboloid_pf(beta, ks), rel=within)


def test_a_linear_limit_state_has_no_curvature_and_sorm_is_form():
    """g = 3 - a . u (|a| = 1, a not along an axis): every curvature 0, pf_SORM = Phi(-3)."""
    a = np.array([0.5, -0.5, 0.7071067811865476])
    shape = _sampled(lambda u: 3.0 - a @ u, 3.0 * a, step=1.0)
    assert shape.kappas == pytest.approx(np.zeros(2), abs=1e-12)
    assert sorm.breitung(3.0, shape.kappas) == pytest.approx(form.failure_probability(3.0), rel=1e-12)
    assert sorm.hohenbichler_rackwitz(3.0, shape.kappas) == pytest.approx(form.failure_probability(3.0), rel=1e-12)


def test_a_rotated_paraboloid_found_by_form_gives_the_unrotated_pf():
    """The paraboloid of curvatures (0.25, -0.1) turned by a random rotation Q, g(u) = g0(Q^T u): FORM's
    iteration (forward differences, as the study makes it) finds u* = Q (0, 0, 3), and SORM about it the same
    curvatures and pf as unrotated; sampling on the axes of u instead of the tangent plane's would mix the
    normal into the Hessian and miss."""
    beta, ks = 3.0, np.array([0.25, -0.1])
    q = _random_rotation(3, 4)

    def g0(v):
        return beta - v[-1] + 0.5 * ks @ v[:-1] ** 2

    def g(u):
        return g0(q.T @ u)

    centre, betas = np.zeros(3), []
    for _ in range(40):
        points = form.gradient_points(centre, 1e-5)
        linearisation = form.Linearisation.of(centre, np.array([g(u) for u in points]), 1e-5)
        betas.append(linearisation.beta)
        if form.converged(betas, 1e-10):
            break
        centre = linearisation.next_u
    design_u = linearisation.next_u
    assert design_u == pytest.approx(q @ np.array([0.0, 0.0, beta]), abs=1e-4)
    shape = _sampled(g, design_u, step=0.5)
    assert shape.kappas == pytest.approx(np.sort(ks), abs=1e-3)
    assert sorm.breitung(linearisation.beta, shape.kappas) == pytest.approx(sorm.breitung(beta, ks), rel=1e-3)
    on_axes = sorm.Curvatures.of(design_u, np.array([g(u) for u in design_u + 0.5 * sorm._offsets(3)]), 0.5)
    assert not np.allclose(on_axes.kappas, np.sort(ks), atol=0.02)


def test_a_limit_state_curved_toward_the_origin_past_the_sphere_has_no_breitung_estimate():
    """kappa = -0.5 at beta = 3: 1 + beta kappa = -0.5, no asymptote: None, not a NaN; the noise range's upper
    end None where the lowered curvatures break it."""
    assert sorm.breitung(3.0, np.array([0.1, -0.5])) is None
    assert sorm.hohenbichler_rackwitz(3.0, np.array([-0.5])) is None
    low, high = sorm.range_from_noise(3.0, np.array([-0.3]), 0.05)
    assert low is not None and high is None
    breitung = sorm.breitung(3.0, np.array([-0.32]))  # 1 + 3 kappa = 0.04, 1 + psi(3) kappa = -0.05
    assert breitung is not None and sorm.hohenbichler_rackwitz(3.0, np.array([-0.32])) is None
    from workflows.probabilistic.form_study import SecondOrder

    line = SecondOrder(pf_breitung=breitung, kappas=(-0.32,), noise=0.01, pf_range=(breitung, None), searches=5,
                       step=1.0, gradient_angle_deg=1.0, fos_at_design_point=1.0).line(3.0)
    assert "Hohenbichler-Rackwitz none" in line and "unbounded below" in line and "nan" not in line


def test_the_noise_bound_holds_every_error_of_values_known_within_their_brackets():
    """g known to +- 0.001 at each point (a FOS bracket of 0.002): the curvatures of 200 perturbed copies stay
    within the bound of the exact ones; the bound scales as 1 / step^2."""
    beta, ks = 2.5, np.array([0.1, -0.05, 0.02])
    design_u = np.r_[0.0, 0.0, 0.0, beta]

    def g(u):
        return 0.2 * (beta - u[-1] + 0.5 * ks @ u[:-1] ** 2)

    points = sorm.curvature_points(design_u, 1.0)
    exact = np.array([g(u) for u in points])
    half = np.full(len(points), 0.001)
    bound = sorm.Curvatures.of(design_u, exact, 1.0, half).noise
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(200):
        shape = sorm.Curvatures.of(design_u, exact + rng.uniform(-0.001, 0.001, exact.size), 1.0, half)
        worst = max(worst, float(np.max(np.abs(shape.kappas - np.sort(ks)))))
    assert 0.2 * bound < worst <= bound
    assert sorm.Curvatures.of(design_u, np.array([g(u) for u in sorm.curvature_points(design_u, 2.0)]), 2.0,
                              half).noise == pytest.approx(bound / 4, rel=0.05)


C_PHI = (REPO / "studies" / "probabilistic_c_phi.toml").read_text()


def _form_text(extra: str = "", realisations: int = 40) -> str:
    return (C_PHI.replace('method = "latin_hypercube"', 'method = "form"')
            .replace("realisations = 40", f"realisations = {realisations}{extra}"))


@pytest.mark.parametrize("text, field", [
    (C_PHI.replace("realisations = 40", "realisations = 40\nsorm = true"), "probabilistic.sorm"),
    (_form_text("\nsorm = true", realisations=10), "probabilistic.realisations"),
    (_form_text("\nsorm = 1"), "probabilistic.sorm"),
    (_form_text("\nsorm = true\nsorm_step = 0"), "probabilistic.sorm_step"),
])
def test_sorm_that_cannot_run_is_one_line_naming_its_field(text, field):
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == field


def _scripted_form(tmp_path, fos_of_u, extra: str = "\nsorm = true", realisations: int = 40):
    """A form study of the c-phi slope whose FOS is ``fos_of_u`` of each point's standard normals (the points and
    rounds of the study, no run): the study type after its last round."""
    from tests.test_form import _fake_outcome
    from workflows.cases import RunOptions
    from workflows.progress import Progress
    from workflows.study_types import study_type

    kind = study_type(parse_study(_form_text(extra, realisations)), tmp_path)
    kind.check(RunOptions(workers=1))
    kind.cases()
    points, outcomes = kind.realisations, {}
    while True:
        for i in range(len(outcomes), points.count):
            outcomes[points.case_id(i)] = _fake_outcome(fos_of_u(points.u[i]))
        if not kind.next_cases(outcomes, Progress()) and kind.finished:
            return kind


def _curved_fos(beta: float, ks, q: np.ndarray, quartic: float = 0.0):
    """FOS = 1 + 0.2 g0(Q^T u), g0 the paraboloid of ``ks`` at ``beta`` (less ``quartic`` v_1^4): its design point
    Q (0, beta)."""
    def fos(u):
        v = q.T @ u
        return 1.0 + 0.2 * (beta - v[-1] + 0.5 * np.dot(ks, v[:-1] ** 2) - quartic * v[0] ** 4)
    return fos


def test_a_form_study_runs_sorm_as_one_more_round_on_the_converged_design_point(tmp_path):
    """Two variables, a FOS curved by k = 0.3 about a turned axis: FORM converges near beta 2.5, then one round of
    5 points; the study's curvature is k (its forward-difference design point is near, not at, u*) and its pf
    Breitung's; the report line states beta, the curvature with its noise bound and the 5 searches."""
    q = _random_rotation(2, 5)
    kind = _scripted_form(tmp_path, _curved_fos(2.5, [0.3], q))
    second = kind.second_order
    assert second is not None and not second.status and second.searches == 5
    assert kind.realisations.count == len(kind.iterations) * 3 + 5
    assert second.kappas == pytest.approx([0.3], abs=0.03)
    assert second.noise == pytest.approx(4 * 0.001 / 0.2, rel=0.05)  # 4 half-brackets over step^2 |grad g|
    assert second.pf_breitung == pytest.approx(sorm.breitung(kind.iterations[-1].beta, np.array(second.kappas)))
    assert second.pf_breitung < form.failure_probability(kind.iterations[-1].beta)
    assert second.beta_breitung > kind.iterations[-1].beta
    line = second.line(kind.iterations[-1].beta)
    assert "SORM (Breitung 1984) beta = " in line and "5 FOS searches" in line and "nan" not in line.lower()


def test_sorm_without_an_asymptote_or_room_keeps_forms_answer_labelled(tmp_path):
    """A FOS that bends toward the origin (g0 = 2.5 - v_2 - 0.03 v_1^4: flat at its design point, the distance's
    minimum, but its second difference over sorm_step = 3 is -0.54 < -1 / beta) and a budget without room for
    the round: each says why in its line and leaves pf_SORM None, FORM's beta standing; without sorm, no round."""
    q = _random_rotation(2, 6)
    curved = _scripted_form(tmp_path / "curved", _curved_fos(2.5, [0.0], q, quartic=0.03),
                            extra="\nsorm = true\nsorm_step = 3")
    second = curved.second_order
    assert second is not None and second.pf_breitung is None and "<= 0" in second.status
    assert "FORM's beta = " in second.line(2.5) and "stands" in second.line(2.5)
    plain = _scripted_form(tmp_path / "plain", _curved_fos(2.5, [0.3], q), extra="")
    assert plain.second_order is None and plain.realisations.count == len(plain.iterations) * 3
    tight = _scripted_form(tmp_path / "tight", _curved_fos(2.5, [0.3], q),
                           realisations=max(11, plain.realisations.count + 4))  # FORM's points, not SORM's 5 more
    assert tight.second_order is not None and "budget" in tight.second_order.status
    assert "budget" in tight.second_order.line(2.5)


@pytest.mark.slow
def test_a_form_study_with_sorm_writes_beta_sorm_and_resumes_without_a_run(tmp_path):
    """The c-phi slope (lognormal c, truncated normal phi, correlated -0.5) at h = 1 m, FORM then SORM's round of 5
    points: probabilistic.nc holds beta_SORM and pf_SORM (Breitung's and Hohenbichler-Rackwitz's, the curvature, its
    noise and the round's searches), its points marked -1; the report states it; run again, every point read
    back (no run) and the same numbers."""
    import xarray as xr

    from workflows.cases import RunOptions
    from workflows.study_types import run_study, study_type

    study = parse_study(_form_text("\nsorm = true"))
    first = run_study(study, tmp_path, RunOptions(workers=2))
    second = first.second_order
    assert first.converged and second is not None and second.searches == 5, second
    ds = xr.load_dataset(tmp_path / "probabilistic.nc")
    assert (ds["form_iteration"].values == -1).sum() == 5 and ds.attrs["sorm_searches"] == 5
    assert ds.attrs["n_fos_searches"] == first.n_searches == 3 * first.iterations + 5
    if second.pf_breitung is None:  # (the slope's curvature decides; either way labelled, never a NaN)
        assert "reliability_index_sorm" not in ds.attrs and ds.attrs["sorm_status"]
    else:
        assert ds.attrs["pf_sorm"] == pytest.approx(second.pf_breitung)
        assert ds.attrs["reliability_index_sorm"] == pytest.approx(-stats.norm.ppf(second.pf_breitung))
        assert ds.attrs["pf_sorm_hr"] == pytest.approx(second.pf_hr)
        assert float(ds.attrs["sorm_curvatures"]) == pytest.approx(second.kappas[0], rel=1e-5)
    lines = study_type(study, tmp_path).report(first, False, None).lines
    assert any(line.startswith("SORM") for line in lines) and "nan" not in " ".join(lines).lower()
    again = run_study(study, tmp_path, RunOptions(workers=2))
    assert again.runs_made == 0 and again.second_order == second


def test_one_variable_has_no_tangent_plane_and_sorm_is_form_without_a_search(tmp_path):
    """One normal cohesion, FOS = c / 7 kPa (the undrained closed form's shape: a monotone g of one u): the limit
    state is a point, pf_SORM = pf_FORM = Phi(-beta) exactly and SORM spends no search."""
    from workflows.cases import RunOptions
    from workflows.progress import Progress
    from workflows.study_types import study_type

    text = C_PHI[: C_PHI.index("[probabilistic]")] + (
        '[probabilistic]\nmethod = "form"\nrealisations = 40\ncompute = "fos"\nfactor = 1.0\nsorm = true\n\n'
        '[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "normal"\nstd = 1000.0\n')
    from tests.test_form import _fake_outcome

    kind = study_type(parse_study(text), tmp_path)
    kind.check(RunOptions(workers=1))
    kind.cases()
    points, outcomes = kind.realisations, {}
    while True:
        for i in range(len(outcomes), points.count):
            outcomes[points.case_id(i)] = _fake_outcome(points.values[i, 0] / 7e3)
        if not kind.next_cases(outcomes, Progress()) and kind.finished:
            break
    beta = kind.iterations[-1].beta
    assert beta == pytest.approx(3.0, abs=1e-3)
    second = kind.second_order
    assert second is not None and second.searches == 0 and points.count == 2 * len(kind.iterations)
    assert second.pf_breitung == second.pf_hr == form.failure_probability(beta)
    assert "no tangent plane" in second.line(beta)
