"""Adaptive refinement of the quickstart slope against its extrapolated FOS, in one command.

    python -m benchmarks.fos_adaptive                        # adaptive 0.35 and 0.25 m from the 1 m quickstart
    python -m benchmarks.fos_adaptive --spacings 0.3 --repeats 2

First the refinement study of ``studies/quickstart.toml`` at h = 1, 0.7071, 0.5 m gives the FOS
at h -> 0 and its band (``[refinement] spacings_m``); then, for each spacing given, the
quickstart with ``[refinement] adaptive_spacing_m`` (the 1 m study, then a zone of that spacing
along the shear band of its first failed run).  Each by the command (2 local workers, warm numba
cache); wall times are of the whole command, the median of ``--repeats``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

import xarray as xr

from benchmarks.study_command import run_study_command

ROOT = Path(__file__).resolve().parents[1]


def run(text: str, folder: Path) -> tuple[xr.Dataset, float]:
    out, wall = run_study_command(text, folder)
    return xr.open_dataset(out / "refinement.nc").load(), wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacings", nargs="+", type=float, default=[0.35, 0.25])
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args(argv)
    quickstart = (ROOT / "studies" / "quickstart.toml").read_text()
    with tempfile.TemporaryDirectory() as scratch:
        levels, wall = run(quickstart + "\n[refinement]\nspacings_m = [1.0, 0.7071, 0.5]\n", Path(scratch) / "levels")
        target = float(levels["fos_extrapolated"])
        print(f"refinement study h = 1, 0.7071, 0.5 m: FOS at h -> 0 {target:.4f} [{levels.attrs['band_low']:.4f}, "
              f"{levels.attrs['band_high']:.4f}] ({levels.attrs['extrapolation_status']}), {wall:.1f} s\n")
        print("| adaptive spacing (m) | particles | FOS [bracket] | against h -> 0 | runs (coarse/refined) | wall (s), median |")
        print("|---|---|---|---|---|---|")
        for spacing in args.spacings:
            text = quickstart + f"\n[refinement]\nadaptive_spacing_m = {spacing:g}\n"
            results = [run(text, Path(scratch) / f"adaptive_{spacing:g}") for _ in range(args.repeats)]
            ds = results[0][0]
            fos, low, high = (float(ds[name].values[-1]) for name in ("fos", "fos_low", "fos_high"))
            runs = "/".join(str(int(n)) for n in ds["n_runs"].values)
            print(f"| {spacing:g} | {int(ds['n_particles'].values[-1]):,} | {fos:.4f} [{low:.4f}, {high:.4f}] | "
                  f"{100 * (fos / target - 1):+.2f}% | {runs} | {statistics.median(w for _, w in results):.1f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
