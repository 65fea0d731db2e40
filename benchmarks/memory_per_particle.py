"""Peak memory per particle of one process holding a simulation (the memory guard's figure).

    python -m benchmarks.memory_per_particle [--spacing 0.1 0.05]

For each spacing, in a fresh process: the reference slope of ``studies/quickstart.toml``, its
scene and simulation, a few steps and one mesh rebuild (Qhull's temporaries are the peak);
the growth of the peak resident memory (``getrusage``) divided by the particle count.
``workflows.memory_guard.BYTES_PER_PARTICLE`` rounds the largest figure up.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MEASURE = """
import resource
from spfem_core.simulation import Simulation
from workflows.scene import build_scene, solver_settings
from workflows.study import parse_study
text = open("studies/quickstart.toml").read().replace("spacing_m = 1.0", "spacing_m = {h}")
study = parse_study(text)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
scene = build_scene(study)
sim = Simulation(scene, solver_settings(study))
sim.run(5 * sim.dt_s)
sim.rebuild_mesh()
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(scene.n_particles, (after - before) * 1024 / scene.n_particles)
"""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.memory_per_particle", description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, nargs="+", default=[0.1, 0.05])
    args = parser.parse_args(argv)
    for h in args.spacing:
        out = subprocess.run([sys.executable, "-c", MEASURE.format(h=h)], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.split()
        print(f"h {h:g} m: {int(out[0]):,} particles, {float(out[1]):,.0f} bytes per particle at the peak", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
