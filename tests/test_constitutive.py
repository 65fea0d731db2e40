"""Objective stress rotation and the plane-strain elastic update."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.constitutive import elastic_increment, rotate_jaumann
from spfem_core.state import XX, XY, YY, ZZ


def test_jaumann_rotation_follows_rigid_spin():
    """Under a rigid spin Omega for time t the stress rotates with the body: sigma(t) = R sigma0 R^T."""
    stress = np.array([[-100.0, -30.0, -50.0, 20.0]])
    omega_rad_s, dt, n = 0.8, 1e-4, 10000  # 0.8 rad in total
    # v = Omega x (-y, x): L_xy = -Omega, L_yx = +Omega
    for _ in range(n):
        rotate_jaumann(stress, 0, -omega_rad_s, omega_rad_s, dt)
    angle = omega_rad_s * dt * n
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    s0 = np.array([[-100.0, 20.0], [20.0, -30.0]])
    expected = R @ s0 @ R.T
    got = np.array([[stress[0, XX], stress[0, XY]], [stress[0, XY], stress[0, YY]]])
    np.testing.assert_allclose(got, expected, rtol=0, atol=0.05)  # first-order in dt: 1e-4 * angle * |s|
    # invariants survive: trace, and the out-of-plane stress is untouched
    assert np.trace(got) == pytest.approx(np.trace(s0), rel=1e-12)
    assert stress[0, ZZ] == -50.0


def test_plane_strain_elastic_increment_matches_hooke():
    E, nu = 80e6, 0.25
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    G = E / (2 * (1 + nu))
    stress = np.zeros((1, 4))
    dxx, dyy, dxy = 1e-4, -3e-5, 2e-5
    elastic_increment(stress, 0, dxx, dyy, dxy, lam, G)
    D = E / ((1 + nu) * (1 - 2 * nu)) * np.array([[1 - nu, nu], [nu, 1 - nu]])
    np.testing.assert_allclose(stress[0, :2], D @ [dxx, dyy], rtol=1e-12)
    assert stress[0, ZZ] == pytest.approx(nu * (stress[0, XX] + stress[0, YY]), rel=1e-12)
    assert np.isclose(stress[0, XY], G * 2 * dxy, rtol=1e-12)
