"""Undrained slopes on a base at the toe: the FOS on a welded base and on a rough (slip) base against
the least circle (``verification.least_circle``), at spacings H/10, H/20, H/40.

    python -m verification.fixed_supports [--angles 45 90] [--per-height 10 20 40]

The slope of ``studies/published/taylor_phi0.toml`` (5 m, cu 20 kPa, gamma 20 kN/m3, D = 1) at
each angle, with ``fos_tolerance`` 0.002; "welded": base particles held in both directions
(``slip = "welded"``); "rough": the base as every FE user writes it, ``vx_m_s = vy_m_s = 0``, which
is a slip support by default (docs/method.md, section 3), as the slope form's base.  About 4 min.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import xarray as xr

from verification.least_circle import slope_least_circle
from verification.study_command import run_study_command

REPO = Path(__file__).resolve().parents[1]
BASES = ("welded", "rough")
BASE = """
[[boundary]]
name = "base"
y_max_m = 0.0
vx_m_s = 0.0
vy_m_s = 0.0
{slip}
[[boundary]]
name = "left"
x_max_m = 0.0
vx_m_s = 0.0
"""
HEIGHT_M, CU_PA, UNIT_WEIGHT_N_M3 = 5.0, 20e3, 20e3


def study_text(angle_deg: float, spacing_m: float, base: str) -> str:
    """The slope at ``angle_deg`` and ``spacing_m`` on a ``base`` of ``BASES``: held in both
    directions, welded or (the default) rough."""
    text = (REPO / "studies" / "published" / "taylor_phi0.toml").read_text()
    text = text[:text.index("[sweep]")].replace("angle_deg = 60.0", f"angle_deg = {angle_deg}")
    text = text.replace("spacing_m = 0.25", f"spacing_m = {spacing_m}")
    text = text.replace("fos_tolerance = 0.005", "fos_tolerance = 0.002")
    return text + BASE.format(slip='slip = "welded"\n' if base == "welded" else "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--angles", nargs="+", type=float, default=[45.0, 90.0])
    parser.add_argument("--per-height", nargs="+", type=float, default=[10.0, 20.0, 40.0])
    args = parser.parse_args(argv)
    print("| angle (deg) | least circle | base | " + " | ".join(f"H/{n:g}" for n in args.per_height) + " |")
    print("|---|---|---|" + "---|" * len(args.per_height))
    with tempfile.TemporaryDirectory() as scratch:
        for angle in args.angles:
            bound = slope_least_circle(HEIGHT_M, angle, CU_PA, UNIT_WEIGHT_N_M3).fos
            for base in BASES:
                cells = []
                for n in args.per_height:
                    out, _ = run_study_command(study_text(angle, HEIGHT_M / n, base),
                                               Path(scratch) / f"{angle:g}_{base}_{n:g}")
                    with xr.open_dataset(out / "summary.nc") as ds:
                        fos = float(ds["fos"])
                    cells.append(f"{fos:.4f} ({100 * (fos / bound - 1):+.2f}%)")
                print(f"| {angle:g} | {bound:.4f} | {base} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
