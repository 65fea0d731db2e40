"""Steps to a quasi-static state: the gravity stage and a stable SRF run, in this tree and another.

    python -m benchmarks.relaxation_steps --compare <checkout before>   # reference slope, h = 1, 0.5, 0.3 m
    python -m benchmarks.relaxation_steps --spacing 0.3 0.15 --srf 1.2

For each spacing the reference slope (``studies/reference_slope.toml``) is relaxed under gravity and
one stable strength-reduction run (SRF ``--srf``, default 1.2, below its FOS 1.37) is made from that
gravity state, on one thread as a dask worker runs it, in a fresh process per tree (each tree's own
sources, the same study text).  This tree also runs with ``elastic_solve = false``: its gravity
stage relaxed from zero stress by damped steps.  Printed per row: the steps and wall time of the
gravity stage and of the SRF run, the SRF run's largest displacement, and the largest difference of
the gravity stress from the other tree's, over the largest stress.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MEASURE = """
import json, sys, time
import numpy as np
from pathlib import Path
from workflows.scene import build_scene, monitor_particles
from workflows.stages.running import begin_stage, new_simulation
from workflows.study import parse_study

text, srf, stress_file = sys.argv[1], float(sys.argv[2]), sys.argv[3]
study = parse_study(text)
scene = build_scene(study)
sim = new_simulation(study, scene, threads=1)
begin_stage(study, sim, 0)
start = time.perf_counter()
gravity = study.stages[0].run(sim, [], next_starts_over=True)
gravity_s = time.perf_counter() - start
np.save(stress_file, sim.nodes.stress_pa)
begin_stage(study, sim, len(study.stages) - 1, start_from=sim.snapshot().stress_state)
start = time.perf_counter()
run = study.strength_reduction.run_at(sim, srf, study, monitor_particles(study, scene), None)
print(json.dumps(dict(particles=scene.n_particles, gravity_steps=int(gravity.n_steps), gravity_s=gravity_s,
                      srf_steps=int(run.n_steps), srf_s=time.perf_counter() - start, converged=bool(run.converged),
                      max_u=float(np.max(run.max_displacement_m)))))
"""


def study_text(spacing_m: float, direct: bool) -> str:
    """The reference slope at ``spacing_m``; ``direct`` False: its gravity stage without the direct solve."""
    text = (ROOT / "studies" / "reference_slope.toml").read_text().replace("spacing_m = 0.3", f"spacing_m = {spacing_m}")
    return text if direct else text.replace("tolerance = 1e-5\n", "tolerance = 1e-5\nelastic_solve = false\n", 1)


def measure(tree: Path, text: str, srf: float, stress_file: Path) -> dict:
    """One row, in a fresh process running ``tree``'s sources."""
    done = subprocess.run([sys.executable, "-c", MEASURE, text, str(srf), str(stress_file)], cwd=tree,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: {done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, nargs="+", default=[1.0, 0.5, 0.3], help="particle spacings (m)")
    parser.add_argument("--srf", type=float, default=1.2, help="SRF of the stable run (default 1.2)")
    parser.add_argument("--compare", type=Path, help="another checkout (e.g. before the direct solve)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        compare(args, Path(folder))


def compare(args, scratch: Path) -> None:
    """The rows of every spacing (module doc), with the gravity stresses kept in ``scratch``."""
    import numpy as np

    rows = [("this", ROOT, True), ("this, no solve", ROOT, False)]
    if args.compare:
        rows.append(("other", args.compare.resolve(), True))
    for _label, tree, direct in rows:  # compile or load every kernel of each tree first
        measure(tree, study_text(1.0, direct if tree == ROOT else True), args.srf, scratch / "warm.npy")
    print(f"{'h (m)':>6} {'particles':>9} {'tree':>15} {'gravity steps':>13} {'gravity s':>9} {'SRF steps':>9} "
          f"{'SRF s':>6} {'SRF max u (m)':>13} {'stress vs other':>15}")
    for spacing in args.spacing:
        measured = {}
        for label, tree, direct in rows:
            measured[label] = measure(tree, study_text(spacing, direct), args.srf, scratch / f"{len(measured)}.npy")
            measured[label]["stress"] = np.load(scratch / f"{len(measured) - 1}.npy")
        reference = measured.get("other", measured["this, no solve"])["stress"]
        for label, row in measured.items():
            difference = np.abs(row["stress"] - reference).max() / np.abs(reference).max()
            print(f"{spacing:6g} {row['particles']:9d} {label:>15} {row['gravity_steps']:13d} {row['gravity_s']:9.2f} "
                  f"{row['srf_steps']:9d} {row['srf_s']:6.2f} {row['max_u']:13.5f} {difference:15.2g}"
                  + ("" if row["converged"] else "  (SRF run not converged)"))


if __name__ == "__main__":
    main()
