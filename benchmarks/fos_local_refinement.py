"""Local refinement against a uniform cloud: the reference slope with a zone of fine particles,
against the whole slope at the zone's spacing, in one command.

    python -m benchmarks.fos_local_refinement                 # band 0.25 m in a 1 m cloud vs uniform 0.25 m
    python -m benchmarks.fos_local_refinement --repeats 2 --band-spacing 0.3
    python -m benchmarks.fos_local_refinement --case weak_layer   # a 1 m weak layer at the toe, refined

Both are ``studies/reference_slope.toml`` with the search tolerance 0.002, run by the command
(2 local workers, warm numba cache), alternated ``--repeats`` times; the table gives the FOS,
particles and wall times (median) and the ratios refined / uniform.  The band is the slip surface
of the uniform run at h = 0.25 m (the particles whose plastic strain passed the 97th percentile
in its first failed run) widened by 1.25 m either side (``BAND``).  ``weak_layer``: the same slope
with a weak layer 1 m thick below the toe (c 2 kPa, phi 10 deg, ``WEAK_LAYER``) and a zone 2 m
thick around it; this case also runs the coarse cloud without the zone (the layer at one or two
rows of particles).
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import tempfile
from pathlib import Path

import xarray as xr

from verification.study_command import run_study_command

ROOT = Path(__file__).resolve().parents[1]
SLIP_LINE_M = [(16, 16.5), (18, 14), (20, 11.9), (22, 10), (24, 8.5), (26, 7.4), (28, 6.5), (30, 5.75), (32, 5.1),
               (34, 4.75), (36, 4.5), (38, 4.5), (40, 4.8), (42, 5.2)]
HALF_WIDTH_M = 1.25
BAND = [[x, y + HALF_WIDTH_M] for x, y in SLIP_LINE_M] + [[x, y - HALF_WIDTH_M] for x, y in SLIP_LINE_M[::-1]]
WEAK_LAYER = """
[[materials]]
name = "weak_layer"
model = "drucker_prager"
dp_fit = "mohr_coulomb_match"
density_kg_m3 = 2000.0
youngs_modulus_pa = 100e6
poisson_ratio = 0.3
cohesion_pa = 2e3
friction_deg = 10.0
dilation_deg = 0.0
region_m = [[0.0, 4.0], [60.0, 4.0], [60.0, 5.0], [0.0, 5.0]]
"""
LAYER_ZONE = [[0.0, 3.5], [60.0, 3.5], [60.0, 5.5], [0.0, 5.5]]


def study_text(name: str, spacing_m: float, band_spacing_m: float | None, weak_layer: bool = False) -> str:
    text = (ROOT / "studies" / "reference_slope.toml").read_text()
    text = re.sub(r'(?m)^name = "reference_slope"', f'name = "{name}"', text, count=1)
    text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)
    text = re.sub(r"(?m)^fos_tolerance = .*$", "fos_tolerance = 0.002", text, count=1)
    if weak_layer:
        text = text.replace("[loads]", WEAK_LAYER + "\n[loads]", 1)
        text = re.sub(r"(?m)^srf_min = .*$", "srf_min = 0.5", text, count=1)
        text = re.sub(r"(?m)^srf_max = .*$", "srf_max = 1.5", text, count=1)
    if band_spacing_m is not None:
        zone = f'[[geometry.refined]]\nname = "zone"\nregion_m = {LAYER_ZONE if weak_layer else BAND}\n' \
               f'spacing_m = {band_spacing_m:g}\n\n'
        text = text.replace("[[materials]]", zone + "[[materials]]", 1)
    return text


def run(text: str, folder: Path) -> dict:
    out, wall = run_study_command(text, folder)
    with xr.open_dataset(out / "summary.nc") as summary:
        fos = summary["fos"]
        return dict(fos=float(fos), low=fos.attrs["fos_low"], high=fos.attrs["fos_high"],
                    particles=summary.attrs["n_particles"], runs=summary.sizes["srf"], wall=wall)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--band-spacing", type=float, default=0.25)
    parser.add_argument("--coarse-spacing", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--case", choices=("slip_band", "weak_layer"), default="slip_band")
    args = parser.parse_args(argv)
    weak = args.case == "weak_layer"
    configurations = {"uniform": study_text("uniform", args.band_spacing, None, weak),
                      "refined band": study_text("refined", args.coarse_spacing, args.band_spacing, weak)}
    if weak:
        configurations["coarse, no zone"] = study_text("coarse", args.coarse_spacing, None, weak)
    results = {name: [] for name in configurations}
    with tempfile.TemporaryDirectory() as scratch:
        for repeat in range(args.repeats):
            order = list(configurations) if repeat % 2 == 0 else list(configurations)[::-1]
            for name in order:
                results[name].append(run(configurations[name], Path(scratch) / name.replace(" ", "_")))
    print("| cloud | particles | FOS [bracket] | runs | wall (s), median |")
    print("|---|---|---|---|---|")
    for name, rows in results.items():
        r = rows[0]
        print(f"| {name} | {r['particles']:,} | {r['fos']:.4f} [{r['low']:.4f}, {r['high']:.4f}] | {r['runs']} | "
              f"{statistics.median(row['wall'] for row in rows):.1f} |")
    uniform, band = results["uniform"], results["refined band"]
    print(f"\nrefined / uniform: particles {band[0]['particles'] / uniform[0]['particles']:.2f}, wall time "
          f"{statistics.median(r['wall'] for r in band) / statistics.median(r['wall'] for r in uniform):.2f}, "
          f"FOS {100 * (band[0]['fos'] / uniform[0]['fos'] - 1):+.2f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
