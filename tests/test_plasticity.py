"""Drucker-Prager and Mohr-Coulomb return maps: properties, fits and a plane-strain collapse."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from spfem_core.materials.drucker_prager import DP_FITS, default_dp_fit, dp_constants, drucker_prager_update
from spfem_core.materials.elastic import elastic_increment
from spfem_core.materials.mohr_coulomb import mohr_coulomb_update
from spfem_core.state import XX, XY, YY

PROPERTY = settings(deadline=None, max_examples=200)
SURFACE_RTOL = 1e-9


# ---------------------------------------------------------------------------- helpers


def lame(youngs, nu):
    """(lambda, G, K) of E, nu."""
    lam = youngs * nu / ((1 + nu) * (1 - 2 * nu))
    shear = youngs / (2 * (1 + nu))
    return lam, shear, lam + 2 * shear / 3


def invariants(row):
    """(I1, sqrt(J2)) of a plane-strain stress row (xx, yy, zz, xy)."""
    p = (row[0] + row[1] + row[2]) / 3
    s = row[:3] - p
    return 3 * p, math.sqrt(0.5 * float(s @ s) + row[3] ** 2)


def in_plane_frame(row):
    """Unit eigenvectors (major, minor) of the in-plane part of a stress row."""
    values, vectors = np.linalg.eigh(np.array([[row[0], row[3]], [row[3], row[1]]]))
    return vectors[:, 1], vectors[:, 0]


def along(row, direction):
    """Normal stress of a row on the in-plane direction n: n . sigma . n."""
    sigma = np.array([[row[0], row[3]], [row[3], row[1]]])
    return float(direction @ sigma @ direction)


def principal(row):
    """Principal stresses s1 >= s2 >= s3 of a plane-strain row (zz is one of them)."""
    centre, radius = 0.5 * (row[0] + row[1]), math.hypot(0.5 * (row[0] - row[1]), row[3])
    return sorted((centre + radius, centre - radius, row[2]), reverse=True)


def dp_yield(row, alpha, k):
    i1, q = invariants(row)
    return alpha * i1 + q - k


def mc_yield(row, c, sin_phi, cos_phi):
    s1, _, s3 = principal(row)
    return (s1 - s3) + (s1 + s3) * sin_phi - 2 * c * cos_phi


def trial_of(stress, increment, lam, shear):
    trial = stress.copy()
    elastic_increment(trial, 0, *increment, lam, shear)
    return trial[0]


def dp_step(stress, increment, lam, shear, constants):
    new = stress.copy()
    result = drucker_prager_update(new, 0, *increment, lam, shear, *constants)
    return new[0], result


def mc_constants(c, phi_deg, psi_deg):
    phi, psi = math.radians(phi_deg), math.radians(psi_deg)
    return c, math.sin(phi), math.cos(phi), math.sin(psi)


def mc_step(stress, increment, lam, shear, constants):
    new = stress.copy()
    result = mohr_coulomb_update(new, 0, *increment, lam, shear, *constants)
    return new[0], result


def plastic_volume(stress, new_row, increment, bulk):
    """tr(d_eps_p) = tr(d) - tr(C^-1 dsigma) = tr(d) - tr(dsigma) / (3K)."""
    return increment[0] + increment[1] - float(np.sum(new_row[:3] - stress[0, :3])) / (3 * bulk)


# warm-up: compile before hypothesis times anything
_WARM = np.array([[-1e5, -2e5, -1.5e5, 3e4]])
drucker_prager_update(_WARM.copy(), 0, 1e-3, -1e-3, 1e-3, 1e7, 1e7, 0.1, 1e4, 0.0)
mohr_coulomb_update(_WARM.copy(), 0, 1e-3, -1e-3, 1e-3, 1e7, 1e7, 1e4, 0.3, 0.95, 0.0)

# ---------------------------------------------------------------------------- strategies

# below ~1e-150 squares underflow (a radius of 1e-196 Pa computes as 0): flush such values to 0
stress_pa = st.floats(-1e6, 2e5).map(lambda x: 0.0 if abs(x) < 1e-6 else x)
shear_pa = st.floats(-3e5, 3e5).map(lambda x: 0.0 if abs(x) < 1e-6 else x)
strain = st.floats(-2e-2, 2e-2).map(lambda x: 0.0 if abs(x) < 1e-15 else x)


@st.composite
def materials(draw, psi_zero=False, with_apex=False):
    """(lambda, G, K, c, phi_deg, psi_deg); ``with_apex``: c >= 1 Pa and phi >= 5 deg."""
    lam, shear, bulk = lame(draw(st.floats(1e6, 1e9)), draw(st.floats(0.0, 0.45)))
    phi = draw(st.floats(5.0, 55.0) if with_apex else st.just(0.0) | st.floats(0.0, 55.0))
    psi = 0.0 if psi_zero else phi * draw(st.sampled_from([0.0, 1.0, 0.5]) | st.floats(0.0, 1.0))
    cohesion = draw(st.floats(1.0, 1e5) if with_apex else st.just(0.0) | st.floats(1.0, 1e5))
    return lam, shear, bulk, cohesion, phi, psi


@st.composite
def states(draw):
    """(stress (1, 4), increment (dxx, dyy, dxy))."""
    stress = np.array([[draw(stress_pa), draw(stress_pa), draw(stress_pa), draw(shear_pa)]])
    return stress, (draw(strain), draw(strain), draw(strain))


# ---------------------------------------------------------------------------- Drucker-Prager


@PROPERTY
@given(materials(), states(), st.sampled_from(DP_FITS))
def test_dp_return_lands_on_the_surface_or_keeps_the_elastic_trial(material, state, fit):
    lam, shear, bulk, c, phi, psi = material
    stress, increment = state
    alpha, k, alpha_psi = dp_constants(c, phi, psi, fit)
    trial = trial_of(stress, increment, lam, shear)
    new, (d_eq, work) = dp_step(stress, increment, lam, shear, (alpha, k, alpha_psi))
    scale = np.max(np.abs(trial)) + c
    f_trial = dp_yield(trial, alpha, k)
    if d_eq == 0.0:
        assert work == 0.0
        assert f_trial <= SURFACE_RTOL * scale
        np.testing.assert_array_equal(new, trial)  # exact: the elastic step is Hooke, untouched
        return
    assert f_trial > 0.0
    assert abs(dp_yield(new, alpha, k)) <= SURFACE_RTOL * scale
    assert work >= -SURFACE_RTOL * scale * d_eq
    i1_trial, q_trial = invariants(trial)
    i1, q = invariants(new)
    # the apex region: G (p_tr - p_apex) >= 3 K alpha_psi sqrt(J2_tr)
    beyond_apex = shear * (alpha * i1_trial - k) - 9 * bulk * alpha * alpha_psi * q_trial
    if alpha > 0 and beyond_apex > 1e-9 * shear * scale:
        assert q <= 1e-12 * scale
        assert i1 / 3 == pytest.approx(k / (3 * alpha), rel=1e-12)
    elif beyond_apex < -1e-9 * shear * scale:
        # face: d_eps_p = dlambda (s / (2 sqrt J2) + alpha_psi I), |d_eps_p|^2 = dlambda^2 (1/2 + 3 alpha_psi^2)
        dlambda = f_trial / (shear + 9 * bulk * alpha * alpha_psi)
        expected = dlambda * math.sqrt(2 / 3 * (0.5 + 3 * alpha_psi**2))
        assert d_eq == pytest.approx(expected, rel=1e-7, abs=1e-12 * scale / shear)


@PROPERTY
@given(materials(), states(), st.sampled_from(DP_FITS))
def test_dp_second_return_is_a_no_op(material, state, fit):
    lam, shear, _, c, phi, psi = material
    stress, increment = state
    constants = dp_constants(c, phi, psi, fit)
    once, _ = dp_step(stress, increment, lam, shear, constants)
    twice, result = dp_step(once[None, :], (0.0, 0.0, 0.0), lam, shear, constants)
    assert result == (0.0, 0.0)
    np.testing.assert_array_equal(twice, once)


@PROPERTY
@given(materials(psi_zero=True), states(), st.sampled_from(DP_FITS))
def test_dp_plastic_flow_is_isochoric_without_dilation(material, state, fit):
    lam, shear, bulk, c, phi, psi = material
    stress, increment = state
    alpha, k, alpha_psi = dp_constants(c, phi, psi, fit)
    assert alpha_psi == 0.0
    new, _ = dp_step(stress, increment, lam, shear, (alpha, k, alpha_psi))
    _, q = invariants(new)
    scale = np.max(np.abs(stress)) + c
    assume(not (alpha > 0 and q <= 1e-12 * scale))  # the apex (tension cut-off) changes volume
    strain_scale = max(abs(x) for x in increment) + scale / bulk
    assert abs(plastic_volume(stress, new, increment, bulk)) <= 1e-9 * strain_scale


@PROPERTY
@given(materials(with_apex=True), st.sampled_from(DP_FITS), st.floats(1e-3, 1e3), st.floats(-1.0, 1.0),
       st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_dp_states_beyond_the_apex_return_to_it(material, fit, excess, u, v, w):
    lam, shear, bulk, c, phi, psi = material
    alpha, k, alpha_psi = dp_constants(c, phi, psi, fit)
    p_apex = k / (3 * alpha)
    p = p_apex * (1 + excess)
    # deviator inside the apex region: sqrt(J2) < G (p - p_apex) / (3 K alpha_psi)
    bound = math.inf if alpha_psi == 0 else shear * (p - p_apex) / (3 * bulk * alpha_psi)
    size = 0.5 * min(bound, p)
    dev = np.array([u, v, -(u + v), w])
    dev_q = math.sqrt(0.5 * float(dev[:3] @ dev[:3]) + w * w)
    assume(dev_q > 0)
    stress = (np.array([p, p, p, 0.0]) + dev * size / dev_q)[None, :]
    new, (d_eq, work) = dp_step(stress, (0.0, 0.0, 0.0), lam, shear, (alpha, k, alpha_psi))
    np.testing.assert_allclose(new, [p_apex, p_apex, p_apex, 0.0], rtol=1e-12, atol=1e-12 * p)
    assert d_eq > 0 and work > 0


def test_dp_von_mises_has_no_apex():
    """phi = 0: radial return at constant pressure, whatever the tension."""
    lam, shear, _ = lame(1e7, 0.3)
    stress = np.array([[5e5, 4e5, 4.5e5, 2e5]])
    alpha, k, alpha_psi = dp_constants(1e4, 0.0, 0.0, "plane_strain_nonassociated")
    new, (d_eq, _) = dp_step(stress, (0.0, 0.0, 0.0), lam, shear, (alpha, k, alpha_psi))
    i1, q = invariants(new)
    assert d_eq > 0
    assert i1 == pytest.approx(np.sum(stress[0, :3]), rel=1e-14)
    assert q == pytest.approx(k, rel=1e-12)


# ---------------------------------------------------------------------------- Mohr-Coulomb


@PROPERTY
@given(materials(), states())
def test_mc_return_lands_on_the_surface_or_keeps_the_elastic_trial(material, state):
    lam, shear, _, c, phi, psi = material
    stress, increment = state
    constants = mc_constants(c, phi, psi)
    trial = trial_of(stress, increment, lam, shear)
    new, (d_eq, work) = mc_step(stress, increment, lam, shear, constants)
    scale = np.max(np.abs(trial)) + c
    f_trial = mc_yield(trial, *constants[:3])
    if d_eq == 0.0:
        assert work == 0.0
        assert f_trial <= SURFACE_RTOL * scale
        np.testing.assert_array_equal(new, trial)
        return
    assert f_trial > 0.0
    assert abs(mc_yield(new, *constants[:3])) <= SURFACE_RTOL * scale
    assert work >= -SURFACE_RTOL * scale * d_eq


@PROPERTY
@given(materials(), states())
def test_mc_keeps_principal_directions_and_order(material, state):
    """The new stress is coaxial with the trial and each direction keeps its rank."""
    lam, shear, _, c, phi, psi = material
    stress, increment = state
    trial = trial_of(stress, increment, lam, shear)
    new, (d_eq, _) = mc_step(stress, increment, lam, shear, mc_constants(c, phi, psi))
    assume(d_eq > 0)
    scale = np.max(np.abs(trial)) + c
    major, minor = in_plane_frame(trial)
    # coaxial in plane: no shear on the trial's principal axes
    sigma = np.array([[new[0], new[3]], [new[3], new[1]]])
    assert abs(float(major @ sigma @ minor)) <= 1e-9 * scale
    old_values = [along(trial, major), along(trial, minor), trial[2]]
    new_values = [along(new, major), along(new, minor), new[2]]
    for i in range(3):
        for j in range(3):
            if old_values[i] > old_values[j]:
                assert new_values[i] >= new_values[j] - 1e-9 * scale


@PROPERTY
@given(materials(), states())
def test_mc_second_return_is_a_no_op(material, state):
    lam, shear, _, c, phi, psi = material
    stress, increment = state
    constants = mc_constants(c, phi, psi)
    once, _ = mc_step(stress, increment, lam, shear, constants)
    twice, result = mc_step(once[None, :], (0.0, 0.0, 0.0), lam, shear, constants)
    assert result == (0.0, 0.0)
    np.testing.assert_array_equal(twice, once)


@PROPERTY
@given(materials(psi_zero=True), states())
def test_mc_plastic_flow_is_isochoric_without_dilation(material, state):
    lam, shear, bulk, c, phi, psi = material
    stress, increment = state
    new, _ = mc_step(stress, increment, lam, shear, mc_constants(c, phi, 0.0))
    scale = np.max(np.abs(stress)) + c
    s1, _, s3 = principal(new)
    assume(not (phi > 0 and s1 - s3 <= 1e-12 * scale))  # the apex changes volume
    strain_scale = max(abs(x) for x in increment) + scale / bulk
    assert abs(plastic_volume(stress, new, increment, bulk)) <= 1e-9 * strain_scale


@PROPERTY
@given(materials(with_apex=True), st.floats(1e-3, 1e3), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
       st.floats(-1.0, 1.0))
def test_mc_states_beyond_the_apex_return_to_it(material, excess, u, v, w):
    lam, shear, bulk, c, phi, psi = material
    constants = mc_constants(c, phi, psi)
    p_apex = c / math.tan(math.radians(phi))
    p = p_apex * (1 + excess)
    dev = np.array([u, v, -(u + v), w]) * 1e-3 * math.sin(math.radians(phi)) * (p - p_apex) * min(1.0, shear / bulk)
    stress = (np.array([p, p, p, 0.0]) + dev)[None, :]
    new, (d_eq, work) = mc_step(stress, (0.0, 0.0, 0.0), lam, shear, constants)
    np.testing.assert_allclose(new, [p_apex, p_apex, p_apex, 0.0], rtol=1e-12, atol=1e-12 * p)
    assert d_eq > 0 and work > 0


def test_mc_edge_returns_make_two_principal_stresses_equal():
    """Triaxial compression (s2 = s3) and extension (s1 = s2) trials return to the matching edge."""
    lam, shear, _ = lame(1e7, 0.3)
    constants = mc_constants(1e4, 30.0, 10.0)
    compression = np.array([[-1e5, -8e5, -8e5, 0.0]])  # s1 = xx, s2 = s3
    new, (d_eq, _) = mc_step(compression, (0.0, 0.0, 0.0), lam, shear, constants)
    s1, s2, s3 = principal(new)
    assert d_eq > 0 and s2 == pytest.approx(s3, rel=1e-12) and s1 > s2
    extension = np.array([[-1e5, -1e5, -9e5, 0.0]])  # s1 = s2, s3 = zz
    new, (d_eq, _) = mc_step(extension, (0.0, 0.0, 0.0), lam, shear, constants)
    s1, s2, s3 = principal(new)
    assert d_eq > 0 and s1 == pytest.approx(s2, rel=1e-12) and s2 > s3
    assert abs(mc_yield(new, *constants[:3])) <= 1e-9 * 9e5


def test_mc_tresca_has_no_apex():
    lam, shear, _ = lame(1e7, 0.3)
    c = 1e4
    new, (d_eq, _) = mc_step(np.array([[5e5, 5e5, 5e5 - 1e5, 0.0]]), (0, 0, 0), lam, shear, mc_constants(c, 0.0, 0.0))
    s1, _, s3 = principal(new)
    assert d_eq > 0 and s1 - s3 == pytest.approx(2 * c, rel=1e-12)


# ---------------------------------------------------------------------------- fits


def test_dp_fits_at_the_granular_column_friction_angle():
    """collapse_refs.md: phi = 19.8 deg gives alpha 0.1108 (plane strain), 0.1172 (inner), 0.1470 (outer)."""
    expected = {"plane_strain_associated": 0.1108, "inner": 0.1172, "outer": 0.1470}
    for fit, alpha in expected.items():
        assert round(dp_constants(0.0, 19.8, 0.0, fit)[0], 4) == alpha
    # the psi = 0 match of the method notes' table: sin(phi) / 3 and c cos(phi)
    alpha, k, alpha_psi = dp_constants(5e3, 19.8, 0.0, "plane_strain_nonassociated")
    assert alpha == pytest.approx(math.sin(math.radians(19.8)) / 3, rel=1e-15)
    assert k == pytest.approx(5e3 * math.cos(math.radians(19.8)), rel=1e-15)
    assert alpha_psi == 0.0


@pytest.mark.parametrize("phi", [10.0, 25.0, 40.0])
def test_dp_nonassociated_fit_equals_the_associated_one_at_psi_equal_phi(phi):
    np.testing.assert_allclose(
        dp_constants(3e3, phi, phi, "plane_strain_nonassociated"),
        dp_constants(3e3, phi, phi, "plane_strain_associated"), rtol=1e-14,
    )


def test_dp_fit_dilation_and_defaults():
    for fit in ("inner", "outer", "plane_strain_associated"):
        alpha, _, alpha_psi = dp_constants(1e3, 30.0, 30.0, fit)
        assert alpha_psi == pytest.approx(alpha, rel=1e-15)
        assert dp_constants(1e3, 30.0, 0.0, fit)[2] == 0.0
    assert default_dp_fit(0.0, 30.0) == "plane_strain_nonassociated"
    assert default_dp_fit(10.0, 30.0) == "plane_strain_nonassociated"
    assert default_dp_fit(30.0, 30.0) == "plane_strain_associated"
    assert default_dp_fit(0.0) == "plane_strain_nonassociated"
    assert set(DP_FITS) == {"inner", "outer", "plane_strain_associated", "plane_strain_nonassociated"}


@pytest.mark.parametrize(
    "args, name",
    [
        ((-1.0, 30.0, 0.0, "inner"), "cohesion_pa"),
        ((1.0, 90.0, 0.0, "inner"), "friction_deg"),
        ((1.0, -1.0, 0.0, "inner"), "friction_deg"),
        ((1.0, 30.0, 31.0, "inner"), "dilation_deg"),
        ((1.0, 30.0, -1.0, "inner"), "dilation_deg"),
        ((float("nan"), 30.0, 0.0, "inner"), "cohesion_pa"),
        ((1.0, 30.0, 0.0, "cap"), "fit"),
    ],
)
def test_dp_constants_reject_bad_input(args, name):
    with pytest.raises(ValueError, match=name):
        dp_constants(*args)


# ---------------------------------------------------------------------------- collapse equivalence

COLLAPSE_E, COLLAPSE_NU = 50e6, 0.3
COLLAPSE_C, COLLAPSE_P0 = 10e3, 50e3


def biaxial_limit(update, constants, d_yy=-2e-4, n_steps=300):
    """Limiting sigma_yy of a plane-strain biaxial test: isotropic start at -p0, sigma_xx = -p0 held.

    Each step applies d_yy and finds d_xx with sigma_xx(d_xx) = -p0 by the secant method
    (sigma_xx is monotone in d_xx; the first guess is the elastic one).
    """
    lam, shear, _ = lame(COLLAPSE_E, COLLAPSE_NU)
    stress = np.full((1, 4), -COLLAPSE_P0)
    stress[0, XY] = 0.0

    def residual(d_xx):
        trial = stress.copy()
        update(trial, 0, d_xx, d_yy, 0.0, lam, shear, *constants)
        return trial[0, XX] + COLLAPSE_P0, trial

    for _ in range(n_steps):
        x0 = -lam * d_yy / (lam + 2 * shear)
        h0, _ = residual(x0)
        x1 = x0 - h0 / (lam + 2 * shear)
        h1, trial = residual(x1)
        for _ in range(50):
            if abs(h1) <= 1e-10 * COLLAPSE_P0 or h1 == h0:
                break
            x2 = x1 - h1 * (x1 - x0) / (h1 - h0)
            x0, h0 = x1, h1
            x1 = x2
            h1, trial = residual(x1)
        assert abs(h1) <= 1e-8 * COLLAPSE_P0
        stress = trial
    return stress[0, YY]


@pytest.mark.parametrize("phi", [20.0, 30.0, 40.0])
def test_plane_strain_collapse_dp_match_equals_mohr_coulomb(phi):
    """psi = 0: MC reaches sigma_1 = sigma_3 Kp + 2 c sqrt(Kp) (compression positive); the
    plane-strain DP match gives the same limit within 1 %, the inner and outer cones do not."""
    sin_phi = math.sin(math.radians(phi))
    kp = (1 + sin_phi) / (1 - sin_phi)
    closed_form = -(COLLAPSE_P0 * kp + 2 * COLLAPSE_C * math.sqrt(kp))  # sigma_yy, tension positive
    mc = biaxial_limit(mohr_coulomb_update, mc_constants(COLLAPSE_C, phi, 0.0))
    assert mc == pytest.approx(closed_form, rel=1e-6)
    matched = biaxial_limit(drucker_prager_update, dp_constants(COLLAPSE_C, phi, 0.0, "plane_strain_nonassociated"))
    assert matched == pytest.approx(mc, rel=0.01)
    for fit in ("inner", "outer"):
        other = biaxial_limit(drucker_prager_update, dp_constants(COLLAPSE_C, phi, 0.0, fit))
        assert abs(other / mc - 1) > 0.01, fit


@pytest.mark.parametrize("phi, psi", [(30.0, 15.0), (30.0, 30.0), (40.0, 10.0)])
def test_plane_strain_collapse_default_fit_matches_mohr_coulomb_with_dilation(phi, psi):
    """With dilation the default DP fit still gives the Mohr-Coulomb limit (same closed form)."""
    sin_phi = math.sin(math.radians(phi))
    kp = (1 + sin_phi) / (1 - sin_phi)
    closed_form = -(COLLAPSE_P0 * kp + 2 * COLLAPSE_C * math.sqrt(kp))
    mc = biaxial_limit(mohr_coulomb_update, mc_constants(COLLAPSE_C, phi, psi))
    assert mc == pytest.approx(closed_form, rel=1e-6)
    fit = default_dp_fit(psi, phi)
    matched = biaxial_limit(drucker_prager_update, dp_constants(COLLAPSE_C, phi, psi, fit))
    assert matched == pytest.approx(mc, rel=0.01)
