"""Elastic column under gravity by dynamic relaxation (uniaxial strain, exact solution).

Base fixed, sides on rollers: sigma_yy = -rho g (H - Y), sigma_xx = nu / (1 - nu) sigma_yy,
with Y the initial height of the particle (the mass above it does not change).
"""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.state import XX, YY, ZZ

RHO, G, H, NU = 2000.0, 10.0, 10.0, 0.3


@pytest.mark.parametrize("beta", [0.0, 0.1])
def test_relaxed_column_matches_uniaxial_strain(make_column, beta):
    scene = make_column(0.25, height_m=H, density=RHO, g=G, nu=NU)
    sim = Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=beta))
    series = sim.relax(damping=0.7, tolerance=1e-5, max_duration_s=20.0)
    assert series.converged
    assert series.unbalanced_force_ratio < 1e-5
    assert "early_stop" in series.notes

    y0 = sim.initial_xy_m[:, 1]
    sigma_yy = -RHO * G * (H - y0)
    sigma_xx = NU / (1 - NU) * sigma_yy
    away = (y0 >= 0.1 * H) & (y0 <= 0.8 * H)
    rel_yy = np.abs(sim.nodes.stress_pa[away, YY] - sigma_yy[away]) / np.abs(sigma_yy[away])
    rel_xx = np.abs(sim.nodes.stress_pa[away, XX] - sigma_xx[away]) / np.abs(sigma_xx[away])
    assert rel_yy.max() < 0.02
    assert rel_xx.max() < 0.02
    # everywhere (edges included) the error stays below 1% of the base stress rho g H
    assert np.abs(sim.nodes.stress_pa[:, YY] - sigma_yy).max() < 0.01 * RHO * G * H
    # plane strain: sigma_zz = nu (sigma_xx + sigma_yy)
    np.testing.assert_allclose(
        sim.nodes.stress_pa[:, ZZ], NU * (sim.nodes.stress_pa[:, XX] + sim.nodes.stress_pa[:, YY]), rtol=1e-9, atol=1e-6
    )


def test_relaxation_reports_non_convergence(make_column):
    scene = make_column(0.5)
    sim = Simulation(scene, SolverSettings(cfl=0.5))
    series = sim.relax(damping=0.7, tolerance=1e-12, max_duration_s=0.05)
    assert series.converged is False
    assert series.time_s[-1] == pytest.approx(0.05, abs=sim.dt_s)
