"""The transient seepage solve against the number of particles: a slope under a day of rain.

    python -m benchmarks.bench_transient_seepage                 # about 700 and 7,000 particles, 3 repeats
    python -m benchmarks.bench_transient_seepage --spacings 1.15 --repeats 1

The scene is ``verification.transient_seepage.slope_problem``: a 10 m slope at 1:2 in van Genuchten
silty sand, 20 mm/h of rain on its ground for 24 h from a hydrostatic start (suction capped at 5 m),
heads held on its two sides, a seepage face; the state saved every hour.  For each spacing: the
particles and triangles, the steps (rejected ones apart), the Picard iterations (linear solves) and
how many of them factorized the matrix (the others: conjugate gradients on the last factors), the
median wall time of the solve over the repeats (mesh and set-up excluded) and per step, the median
CPU time of the process (the solve runs on one core: on a shared machine the CPU time is the cost,
the wall time grows with the other load), and the water balance's closure.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacings", type=float, nargs="+", default=[1.15, 0.36])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rain-mm-h", type=float, default=20.0)
    args = parser.parse_args(argv)
    from spfem_core.transient_seepage import solve_transient_flow
    from verification.transient_seepage import HOUR_S, slope_problem

    print(f"A slope under {args.rain_mm_h:g} mm/h for 24 h, saved hourly; median of {args.repeats}\n")
    print("| h (m) | particles | triangles | steps (rejected) | Picard iterations | factorizations | solve, wall (s) | "
          "CPU (s) | per step (ms) | closure |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for spacing in args.spacings:
        xy, problem = slope_problem(spacing, rain_mm_h=args.rain_mm_h)
        walls, cpus = [], []
        for _ in range(args.repeats):
            start, start_cpu = time.perf_counter(), time.process_time()
            solution = solve_transient_flow(problem, np.arange(1.0, 24.5) * HOUR_S)
            walls.append(time.perf_counter() - start)
            cpus.append(time.process_time() - start_cpu)
        wall, cpu = statistics.median(walls), statistics.median(cpus)
        steps = solution.step_s.size
        print(f"| {spacing:g} | {xy.shape[0]} | {problem.elem_nodes.shape[0]} | {steps} ({solution.rejected_steps}) | "
              f"{solution.solves} | {solution.factorizations} | {wall:.2f} | {cpu:.2f} | {1e3 * wall / steps:.1f} | "
              f"{solution.balance_fraction()[-1]:.1e} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
