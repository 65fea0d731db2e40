"""The error-controlled FOS of the reference slope: its band's robustness to the clouds' jitter
seeds, and its wall time against the uniform h = 0.3 m study, both in one command.

    python -m benchmarks.fos_controlled                 # three seeds, then 3 alternated timings of each
    python -m benchmarks.fos_controlled --seeds 0 1 2 --repeats 3

1. ``studies/fos_controlled.toml`` (adaptive from h = 1 m, target +-0.5%) with ``geometry.seed`` =
   each seed (each level's jitter seed is geometry.seed + its index): f0 +- U of each, and whether
   every f0 lies within every other's band.
2. Wall time of the whole command, ``studies/fos_controlled.toml`` against
   ``studies/reference_slope.toml`` (uniform 0.3 m, no band), alternated, 2 local workers, the
   numba cache on disk (warmed by a first run that is not counted): min, median, max of each and
   the ratio of the medians.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

import xarray as xr

from verification.study_command import run_study_command

ROOT = Path(__file__).resolve().parents[1]
CONTROLLED = ROOT / "studies" / "fos_controlled.toml"
UNIFORM = ROOT / "studies" / "reference_slope.toml"


def _with_seed(text: str, seed: int) -> str:
    return text.replace("spacing_m = 1.0\n", f"spacing_m = 1.0\nseed = {seed}\n", 1)


def robustness(seeds: list[int], scratch: Path) -> None:
    print("| seed | levels (band spacing m: FOS) | f0 +- U (95%) | band | trusted | wall (s) |")
    print("|---|---|---|---|---|---|")
    bands = []
    for seed in seeds:
        out, wall = run_study_command(_with_seed(CONTROLLED.read_text(), seed), scratch / f"seed{seed}")
        with xr.open_dataset(out / "refinement.nc") as ds:
            f0, u = float(ds["fos_limit"]), float(ds["fos_uncertainty"])
            levels = ", ".join(f"{h:.3g}: {f:.4f}" for h, f in zip(ds["spacing"].values, ds["fos"].values))
            trusted = "yes" if ds.attrs["band_trusted"] else "no"
        bands.append((f0, u))
        print(f"| {seed} | {levels} | {f0:.4f} +- {u:.4f} (+-{100 * u / f0:.2f}%) | [{f0 - u:.4f}, {f0 + u:.4f}] | "
              f"{trusted} | {wall:.1f} |", flush=True)
    within = all(abs(a - b) <= ub for a, _ in bands for b, ub in bands)
    print(f"\nevery f0 within every other's band: {'yes' if within else 'NO'}; widest band "
          f"+-{100 * max(u / f0 for f0, u in bands):.2f}%; f0 from {min(f for f, _ in bands):.4f} to "
          f"{max(f for f, _ in bands):.4f}\n")


def timing(repeats: int, scratch: Path) -> None:
    run_study_command(CONTROLLED.read_text(), scratch / "warm")  # the numba cache on disk
    walls: dict[str, list[float]] = {"controlled": [], "uniform": []}
    for i in range(repeats):
        for name, path in (("controlled", CONTROLLED), ("uniform", UNIFORM)):
            _, wall = run_study_command(path.read_text(), scratch / f"{name}{i}")
            walls[name].append(wall)
    print("| study | what it gives | min (s) | median (s) | max (s) |")
    print("|---|---|---|---|---|")
    gives = {"controlled": "FOS at h -> 0 +- U (adaptive from 1 m)", "uniform": "FOS at h = 0.3 m, no band"}
    for name, values in walls.items():
        print(f"| {name} | {gives[name]} | {min(values):.1f} | {statistics.median(values):.1f} | {max(values):.1f} |")
    print(f"\nmedian controlled / median uniform: "
          f"{statistics.median(walls['controlled']) / statistics.median(walls['uniform']):.2f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-robustness", action="store_true")
    parser.add_argument("--skip-timing", action="store_true")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        if not args.skip_robustness:
            robustness(args.seeds, Path(scratch))
        if not args.skip_timing:
            timing(args.repeats, Path(scratch))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
