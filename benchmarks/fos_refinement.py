"""The refinement study on the published slopes: FOS per level, observed order, the FOS at h -> 0
and its GCI band, against each reference.

    python -m benchmarks.fos_refinement                            # every case, levels H/10, H/14.1, H/20
    python -m benchmarks.fos_refinement --cases griffiths_lane_ex4 --spacings-per-height 20 28.28 40

Each case is a shipped study file with ``[refinement] spacings_m = H / n`` for the given n, run by
the command (2 local workers, warm numba cache); the numbers come from ``refinement.nc``.
Error = FOS / reference - 1; "holds": the band contains the reference.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import xarray as xr

from benchmarks.fos_protocols import CASES
from benchmarks.study_command import run_study_command
from workflows.study import parse_study

ROOT = Path(__file__).resolve().parents[1]


def run(case: str, per_height: list[float], scratch: Path) -> tuple[xr.Dataset, float]:
    text = (ROOT / CASES[case][0]).read_text()
    height = parse_study(text).slope_height_m
    spacings = ", ".join(f"{height / n:.6g}" for n in per_height)
    out, wall = run_study_command(text + f"\n[refinement]\nspacings_m = [{spacings}]\n", scratch / case)
    return xr.open_dataset(out / "refinement.nc").load(), wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--spacings-per-height", nargs="+", type=float, default=[10.0, 14.142, 20.0])
    args = parser.parse_args(argv)
    print("| case | reference | FOS per level (h in m: FOS) | runs per level | order | FOS at h -> 0 [band] | "
          "status | error | holds | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for case in args.cases:
            ds, wall = run(case, args.spacings_per_height, Path(scratch))
            reference = CASES[case][1]
            levels = ", ".join(f"{h:.3g}: {f:.4f}" for h, f in zip(ds["spacing"].values, ds["fos"].values))
            runs = "/".join(str(int(n)) for n in ds["n_runs"].values)
            fos, low, high = float(ds["fos_extrapolated"]), ds.attrs["band_low"], ds.attrs["band_high"]
            holds = "yes" if low <= reference <= high else "no"
            print(f"| {case} | {reference:g} | {levels} | {runs} | {ds.attrs['observed_order']:.2g} | "
                  f"{fos:.4f} [{low:.4f}, {high:.4f}] | {ds.attrs['extrapolation_status']} | "
                  f"{100 * (fos / reference - 1):+.1f}% | {holds} | {wall:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
