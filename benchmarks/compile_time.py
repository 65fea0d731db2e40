"""Where a cold start's compile time goes: numba's compile events of one ``warm_up()``.

    python -m benchmarks.compile_time            # the one-thread step, as an SRF run on a worker
    python -m benchmarks.compile_time --threads  # then a 10k-particle beam on all cores

Runs in this process on an empty numba cache (a fresh temporary ``SPFEM_CACHE_DIR``), listens
to numba's ``numba:compile`` events and prints, per compiled function, the seconds spent in it
alone (exclusive: without the functions it compiled on the way) and with them (inclusive),
largest first, and the wall time of each phase.  numba's own overloads (``np.zeros``, an
array's ``max``) appear under their implementation's name.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

os.environ["SPFEM_CACHE_DIR"] = tempfile.mkdtemp(prefix="spfem-compile-")  # before spfem_core is imported

import numpy as np  # noqa: E402
from numba.core import event  # noqa: E402

from spfem_core import MaterialTable, Scene, SolverSettings  # noqa: E402
from spfem_core.cloud import particles_in_polygon  # noqa: E402
from spfem_core.simulation import Simulation  # noqa: E402
from spfem_core.warmup import warm_up  # noqa: E402


class CompileTimes(event.Listener):
    """Inclusive and exclusive seconds per compiled function name."""

    def __init__(self):
        self.inclusive: dict[str, float] = {}
        self.children: dict[str, float] = {}
        self._stack: list[tuple[str, float]] = []

    def on_start(self, event_):
        self._stack.append((event_.data["dispatcher"].py_func.__qualname__, time.perf_counter()))

    def on_end(self, event_):
        name, start = self._stack.pop()
        seconds = time.perf_counter() - start
        self.inclusive[name] = self.inclusive.get(name, 0.0) + seconds
        if self._stack:
            parent = self._stack[-1][0]
            self.children[parent] = self.children.get(parent, 0.0) + seconds

    def exclusive(self) -> dict[str, float]:
        return {name: total - self.children.get(name, 0.0) for name, total in self.inclusive.items()}


def threaded_beam() -> None:
    """A few steps of the elastic beam at 10k particles, on all cores (the threaded step)."""
    h = 0.02 / 10**0.5
    xy = particles_in_polygon([[0.0, 0.0], [2.0, 0.0], [2.0, 0.2], [0.0, 0.2]], h)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("beam", 1850.0, 80e6, 0.25), h,
                  gravity_m_s2=[0.0, -9.8])
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    sim = Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1))
    sim.run(5 * sim.dt_s)
    print(f"threaded beam: {sim.n_particles} particles on {sim.threads} threads")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", action="store_true", help="also compile the threaded step")
    parser.add_argument("--top", type=int, default=25, help="functions to list")
    args = parser.parse_args()
    times = CompileTimes()
    event.register("numba:compile", times)
    phases = [("warm_up (one thread)", warm_up)] + ([("threaded beam", threaded_beam)] if args.threads else [])
    for label, phase in phases:
        start = time.perf_counter()
        phase()
        print(f"{label}: {time.perf_counter() - start:.2f} s wall")
    exclusive = times.exclusive()
    print(f"{'alone (s)':>10} {'with callees (s)':>17}  function")
    for name, seconds in sorted(exclusive.items(), key=lambda item: -item[1])[: args.top]:
        print(f"{seconds:10.3f} {times.inclusive[name]:17.3f}  {name}")
    print(f"{sum(exclusive.values()):10.3f} {'':17}  all {len(exclusive)} functions")


if __name__ == "__main__":
    main()
