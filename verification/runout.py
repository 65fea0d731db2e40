"""Runout metrics of a runout study at several particle spacings (does the runout converge?).

    python -m verification.runout studies/runout_reference_slope.toml [--spacings 1.0 0.5 0.25]
    python -m verification.runout studies/runout_softening.toml

Runs the study at each spacing and prints, for every runout stage, the runout, retrogression,
sliding-mass area, largest speed, time to rest and energy-budget error (``workflows.runout.metrics``)
with the particle count and the wall time; docs/verification.md quotes them.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import xarray as xr

from workflows.stages import RunoutStage
from workflows.study import load_study, parse_study
from workflows.study_types import run_study

COLUMNS = ("runout_m", "retrogression_m", "sliding_mass_area_m2", "max_speed_m_s", "time_to_rest_s",
           "energy_budget_error")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m verification.runout", description=__doc__.splitlines()[0])
    parser.add_argument("study", type=Path)
    parser.add_argument("--spacings", type=float, nargs="+", default=[1.0, 0.5, 0.25], help="particle spacings (m)")
    args = parser.parse_args(argv)
    base = load_study(args.study)
    print(f"{base.name}: runout metrics against the particle spacing")
    print(f"{'stage':>10} {'h (m)':>6} {'particles':>9} {'runout':>8} {'retro':>8} {'area m2':>8} {'vmax':>6} "
          f"{'rest s':>7} {'budget':>8} {'wall s':>7}")
    with tempfile.TemporaryDirectory() as tmp:
        for spacing in args.spacings:
            study = parse_study(base.source_text.replace(f"spacing_m = {base.geometry.spacing_m}",
                                                         f"spacing_m = {spacing}"))
            start = time.perf_counter()
            run = run_study(study, Path(tmp) / f"h{spacing:g}")
            wall = time.perf_counter() - start
            for stage, path in zip(study.stages, run.paths):
                if not isinstance(stage, RunoutStage):
                    continue
                with xr.open_dataset(path) as ds:
                    values = [float(ds[name]) for name in COLUMNS]
                print(f"{stage.name:>10} {spacing:6g} {run.n_particles:9d} {values[0]:8.2f} {values[1]:8.2f} "
                      f"{values[2]:8.1f} {values[3]:6.2f} {values[4]:7.2f} {100 * values[5]:+7.2f}% {wall:7.1f}")


if __name__ == "__main__":
    main()
