"""The stress update alone (``constitutive.update_stress``, one thread) on a flowing sand column,
run by any checkout: the plastic return maps without the rest of the step.

    python benchmarks/stress_update.py TREE MODEL      # MODEL: drucker_prager, mohr_coulomb, tresca

The column of ``benchmarks/steps.py`` (8,064 particles at h = 3.2 mm) flows for 300 steps; then
300 stress updates of its state (with 20 times the step's dt, so that most particles yield) are
timed 7 times, each from the same state.  Prints the fastest and the median of the 7 and the
plastic work of the last update (the same in two trees that compute the same).
"""

import os
import subprocess
import sys
import time
from pathlib import Path

TREE_VARIABLE = "SPFEM_FOS_BENCH_TREE"
"""Set in the process that measures: the checkout whose ``spfem_core`` it imports."""
if os.environ.get(TREE_VARIABLE) is None:  # the launcher: the measurement runs in a process of TREE's own
    tree = Path(sys.argv[1]).resolve()
    own = {**os.environ, "PYTHONPATH": str(tree), TREE_VARIABLE: str(tree)}
    sys.exit(subprocess.run([sys.executable, str(Path(__file__).resolve()), *sys.argv[1:]], cwd=tree,
                            env=own).returncode)

tree, model = sys.argv[1], sys.argv[2]

import numba  # noqa: E402
import numpy as np  # noqa: E402

from spfem_core import MaterialTable, Scene, SolverSettings  # noqa: E402
from spfem_core.cloud import particles_in_polygon  # noqa: E402
from spfem_core.constitutive import update_stress  # noqa: E402
from spfem_core.jit import kernel_threads  # noqa: E402
from spfem_core.simulation import Simulation  # noqa: E402

h = 0.0032
xy = particles_in_polygon([[0.0, 0.0], [0.2, 0.0], [0.2, 0.4], [0.0, 0.4]], h)
strength = ({"cohesion_pa": 0.0, "friction_deg": 30.0, "dilation_deg": 0.0} if model != "tresca"
            else {"undrained_shear_strength_pa": 2000.0})
scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.single("sand", model, 2000.0, 5e6, 0.3, **strength),
              h, gravity_m_s2=[0.0, -9.81])
scene.add_wall(-0.1, 0.0, 2.0, 0.0, friction=0.5)
scene.add_wall(0.0, 1.0, 0.0, 0.0, friction=0.0)
sim = Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1, threads=1))
sim.run(300 * sim.dt_s, record_interval_s=300 * sim.dt_s)


@numba.njit(fastmath=True, error_model="numpy")
def many(n, L, area, stress, strain, rows, codes, lame, shear, params, dt, threads):
    work = 0.0
    for _ in range(n):
        work = update_stress(L, area, stress, strain, rows, codes, lame, shear, params, dt, threads)
    return work


arrays = sim.material_arrays
rows = sim.nodes.material_row if hasattr(sim.nodes, "material_row") else sim.nodes.material
state = (sim.scratch.velocity_gradient.copy(), sim.scratch.area_m2.copy())


def timed(n):
    stress, strain = sim.nodes.stress_pa.copy(), sim.nodes.plastic_strain.copy()
    start = time.perf_counter()
    work = many(n, *state, stress, strain, rows, arrays.model, arrays.lame_lambda_pa, arrays.shear_modulus_pa,
                arrays.params, 20 * sim.dt_s, kernel_threads(1))
    return time.perf_counter() - start, work


timed(1)  # compile
times = sorted(timed(300)[0] for _ in range(7))
print(f"{tree} {model}: fastest {times[0] * 1e3:.1f} ms, median {times[3] * 1e3:.1f} ms per 300 updates, "
      f"work {timed(1)[1]:.6e}")
