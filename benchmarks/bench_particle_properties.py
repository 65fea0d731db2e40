"""The cost of per-particle soil properties: throughput with a material row against a row per particle.

    python -m benchmarks.bench_particle_properties             # sand column and beam, 1k-40k particles
    python -m benchmarks.bench_particle_properties --quick     # one repeat per size

The same scenes as ``bench_core`` (the plastic sand column flowing on a rough floor: every particle
yields, the walls act, the mesh is rebuilt; the elastic beam), once with the material's row (one
row for every particle) and once with the strength and stiffness given per particle
(``Scene.node_properties``: c, phi and E, each equal to the material's, so the two runs compute the
same numbers and differ only in the table the kernels read: one row, or a row per particle).
Each measurement runs in a fresh process with a warm numba cache; the two alternate, and the
median throughput of each and their ratio are printed.  A scene without per-particle properties
runs exactly the code it ran before they existed (``bench_core --compare``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys

from benchmarks.bench_core import BEAM, COLUMN_SPACINGS_M, ROOT, SAND_COLUMN, SPACINGS_M, _python

PER_PARTICLE = """
import numpy as np
from spfem_core import Scene

def per_particle(sim, **columns):
    '''The simulation's scene again, with ``columns`` given per particle (each the material's value).'''
    scene = sim.scene
    n = scene.n_particles
    own = {key: np.full(n, value) for key, value in columns.items()}
    again = Scene(scene.node_xy_m, scene.node_material, scene.materials, scene.spacing_m,
                  gravity_m_s2=scene.gravity_m_s2, node_fixed=scene.node_fixed,
                  node_fixed_velocity_m_s=scene.node_fixed_velocity_m_s, wall_xy_m=scene.wall_xy_m,
                  wall_friction=scene.wall_friction, node_properties=own)
    return type(sim)(again, sim.settings)
"""

MEASURE = """
import json, time
rates = []
for _ in range({repeats}):
    sim = {make}
    if {own}:
        sim = per_particle(sim, **{columns})
    n = sim.n_particles
    steps = max(200, int(1.5e7 / n))
    sim.run(20 * sim.dt_s)
    start = time.perf_counter()
    series = sim.run(steps * sim.dt_s, record_interval_s=steps * sim.dt_s)
    rates.append(n * series.n_steps / (time.perf_counter() - start))
print(json.dumps({{"n": n, "rows": sim.particle_materials.n_rows, "rates": rates}}))
"""

SCENES = {
    "column": (SAND_COLUMN, "sand_column({h!r}, 0.1)", {"cohesion_pa": 0.0, "friction_deg": 30.0,
                                                         "youngs_modulus_pa": 5e6}, COLUMN_SPACINGS_M),
    "beam": (BEAM, "beam({h!r}, 0.1)", {"youngs_modulus_pa": 80e6}, SPACINGS_M),
}
"""name -> (source, the call that makes the simulation, the columns given per particle, spacings)."""


def throughput(scene: str, spacing_m: float, own: bool, repeats: int) -> tuple[int, int, float]:
    """(particles, rows of the material table, median particle-steps per second)."""
    source, make, columns, _ = SCENES[scene]
    code = source + PER_PARTICLE + MEASURE.format(repeats=repeats, make=make.format(h=spacing_m), own=own,
                                                  columns=columns)
    result = json.loads(_python(ROOT, code))
    return result["n"], result["rows"], statistics.median(result["rates"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_particle_properties",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat per size")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else 3
    _python(ROOT, SCENES["beam"][0] + "\nsim = beam(0.05, 0.1)\nsim.run(20 * sim.dt_s)\nprint('warm')")
    print(f"{'scene':>7} {'particles':>9} {'material row M/s':>17} {'row per particle M/s':>21} {'ratio':>6}"
          "   (M particle-steps/s, medians; ratio: per particle / material row)")
    for scene, (_, _, _, spacings) in SCENES.items():
        for size in ("1k", "10k", "40k"):
            rates: dict[bool, list[float]] = {False: [], True: []}
            n = 0
            for _ in range(repeats):  # alternated
                for own in (False, True):
                    n, rows, rate = throughput(scene, spacings[size], own, 1)
                    assert rows == (n if own else 1), rows
                    rates[own].append(rate)
            shared, own = statistics.median(rates[False]), statistics.median(rates[True])
            print(f"{scene:>7} {n:9d} {shared / 1e6:17.2f} {own / 1e6:21.2f} {own / shared:6.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
