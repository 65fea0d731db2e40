"""A fixed number of steps of one bench_core scene in a fresh process, run by any checkout: the
command to time whole, alternated against another tree (``farm-bench --vs``, ``hyperfine``).

    python benchmarks/steps.py TREE SCENE MODEL THREADS STEPS [SPACING_M]

TREE: the checkout whose ``spfem_core`` runs, in a process of its own (working directory and
PYTHONPATH TREE; this file's scene code is used for both);
SCENE: ``column`` (the sand column on a rough floor) or ``beam`` (the elastic cantilever),
bench_core's two scenes; MODEL: the column's material model (``mohr_coulomb``, ``drucker_prager``,
``elastic``; the beam is elastic); THREADS: 0 for all cores, 1 for a dask worker's one; STEPS;
SPACING_M (default: about 10k particles).  Prints the particles, threads and the sum of |stress|
(the same in two trees that compute the same).  Example, the one-thread Drucker-Prager column
of docs/benchmarks.md against a checkout before:

    farm-bench -n 5 --vs 'python benchmarks/steps.py ../before column drucker_prager 1 2500 0.0032' \\
        -- python benchmarks/steps.py . column drucker_prager 1 2500 0.0032
"""

import os
import subprocess
import sys
from pathlib import Path

TREE_VARIABLE = "SPFEM_FOS_BENCH_TREE"
"""Set in the process that measures: the checkout whose ``spfem_core`` it imports."""
if os.environ.get(TREE_VARIABLE) is None:  # the launcher: the measurement runs in a process of TREE's own
    tree = Path(sys.argv[1]).resolve()
    own = {**os.environ, "PYTHONPATH": str(tree), TREE_VARIABLE: str(tree)}
    sys.exit(subprocess.run([sys.executable, str(Path(__file__).resolve()), *sys.argv[1:]], cwd=tree,
                            env=own).returncode)

scene, model, threads, steps = sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])

import numpy as np  # noqa: E402

from spfem_core import MaterialTable, Scene, SolverSettings  # noqa: E402
from spfem_core.cloud import particles_in_polygon  # noqa: E402
from spfem_core.simulation import Simulation  # noqa: E402

if scene == "column":
    h = float(sys.argv[6]) if len(sys.argv) > 6 else 0.002 * 2**0.5  # bench_core's 10k
    xy = particles_in_polygon([[0.0, 0.0], [0.2, 0.0], [0.2, 0.4], [0.0, 0.4]], h)
    soil = MaterialTable.single("sand", model, 2000.0, 5e6, 0.3, 0.0, 30.0, 0.0)
    built = Scene(xy, np.zeros(len(xy), dtype=np.int64), soil, h, gravity_m_s2=[0.0, -9.81])
    built.add_wall(-0.1, 0.0, 2.0, 0.0, friction=0.5)
    built.add_wall(0.0, 1.0, 0.0, 0.0, friction=0.0)
elif scene == "beam":
    h = float(sys.argv[6]) if len(sys.argv) > 6 else 0.002 * 10**0.5  # bench_core's 10k
    xy = particles_in_polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]], h)
    built = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("beam", 1850.0, 80e6, 0.25), h,
                  gravity_m_s2=[0.0, -9.8])
    built.fix(built.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
else:
    raise SystemExit(f"scene: must be column or beam, got {scene!r}")
sim = Simulation(built, SolverSettings(cfl=0.5, stabilisation_beta=0.1, threads=threads))
sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
print(sim.n_particles, sim.threads, float(np.abs(sim.nodes.stress_pa).sum()))
