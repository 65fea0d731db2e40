"""Measured stability limit of the explicit step against the stabilisation beta.

    python -m benchmarks.stability_limit

Bisects, for the beam lattice (h = 0.04 m) and the jittered beam (jitter 0.25), the largest
cfl (time step / critical step, ``spfem_core.timestep``) that runs 0.3 s without a divergence, for
beta = 0, 0.1, 0.3 and 1.  The refusal rule cfl <= 1/(1 + beta) must sit below every limit.
"""

from __future__ import annotations

from spfem_core.divergence import DivergenceError
from spfem_core.settings import SolverSettings
from spfem_core.simulation import Simulation
from spfem_core.timestep import max_stable_cfl
from verification.scenes import beam_scene


def stable(make_scene, cfl: float, beta: float, duration_s: float) -> bool:
    sim = Simulation(make_scene(), SolverSettings(cfl=0.5 * max_stable_cfl(beta), stabilisation_beta=beta))
    sim.dt_s = cfl * sim.critical_dt_s  # bypass the refusal on purpose
    try:
        sim.run(duration_s)
    except DivergenceError:
        return False
    return True


def main() -> None:
    scenes = {"beam lattice": lambda: beam_scene(0.04), "beam jitter 0.25": lambda: beam_scene(0.04, jitter=0.25)}
    print(f"{'scene':>18} {'beta':>5} {'measured limit cfl':>19} {'accepted cfl':>13}")
    for name, make_scene in scenes.items():
        for beta in (0.0, 0.1, 0.3, 1.0):
            low, high = 0.5, 4.0
            for _ in range(7):
                mid = 0.5 * (low + high)
                low, high = (mid, high) if stable(make_scene, mid, beta, 0.3) else (low, mid)
            print(f"{name:>18} {beta:5.2f} {low:19.3f} {max_stable_cfl(beta):13.3f}")


if __name__ == "__main__":
    main()
