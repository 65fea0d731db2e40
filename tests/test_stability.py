"""Time-step refusal and divergence detection: an unstable run never ends silently."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.divergence import DivergenceError
from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.state import XX
from spfem_core.timestep import UnstableTimeStepError, max_stable_cfl


@pytest.mark.parametrize("beta", [0.0, 0.1, 1.0])
def test_cfl_above_the_stable_limit_is_refused(make_beam, beta):
    limit = max_stable_cfl(beta)
    Simulation(make_beam(0.05), SolverSettings(cfl=limit, stabilisation_beta=beta))  # accepted
    with pytest.raises(UnstableTimeStepError, match=r"cfl = .* outside"):
        Simulation(make_beam(0.05), SolverSettings(cfl=1.01 * limit, stabilisation_beta=beta))


def test_dt_above_the_critical_step_is_refused_with_the_limit_in_the_message(make_beam):
    probe = Simulation(make_beam(0.05), SolverSettings(stabilisation_beta=0.1))
    with pytest.raises(UnstableTimeStepError, match=r"dt_s = .* above the stable time step"):
        Simulation(make_beam(0.05), SolverSettings(dt_s=2 * probe.critical_dt_s, stabilisation_beta=0.1))
    ok = Simulation(make_beam(0.05), SolverSettings(dt_s=0.5 * probe.critical_dt_s, stabilisation_beta=0.1))
    assert ok.dt_s == 0.5 * probe.critical_dt_s


@pytest.mark.parametrize("cfl_factor", [2.4, 3.0, 6.0])
def test_forced_unstable_step_is_reported_as_divergence_with_step_and_time(make_column, cfl_factor):
    """Bypass the refusal (as a bug or a bad remesh could): the run must stop with an error that
    names the step and the time, and keep the records made so far."""
    sim = Simulation(make_column(0.5), SolverSettings(cfl=0.5))
    sim.dt_s = cfl_factor * sim.critical_dt_s
    with pytest.raises(DivergenceError, match=r"diverged at step \d+ \(t = [0-9.e-]+ s\)") as info:
        sim.run(1.0, record_interval_s=sim.dt_s)
    assert info.value.step > 0 and 0 < info.value.time_s < 1.0
    assert info.value.partial is not None and info.value.partial.time_s.size >= 1


def test_nan_stress_is_reported_as_divergence(make_beam):
    sim = Simulation(make_beam(0.05), SolverSettings(cfl=0.5))
    sim.nodes.stress_pa[10, XX] = np.nan
    with pytest.raises(DivergenceError, match="not finite|created energy"):
        sim.run(0.01)


def test_stabilisation_dissipation_scales_with_dt(make_beam):
    """The bond force is an increment over one step: a viscosity eta = beta E dt / 2.  Over the
    same physical time, halving dt must roughly halve the energy it removes (ratio 1.8-2.2)."""
    removed = []
    for cfl in (0.5, 0.25):
        sim = Simulation(make_beam(0.05), SolverSettings(cfl=cfl, stabilisation_beta=0.1))
        series = sim.run(0.4)
        removed.append(series.energy("stabilisation_dissipated")[-1])
    assert 1.8 < removed[0] / removed[1] < 2.2
