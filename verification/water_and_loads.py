"""Water, loads and earthquakes against their references.

    python -m verification.water_and_loads strip [--spacings 0.5 0.25 0.125]
    python -m verification.water_and_loads drawdown [--spacing H]
    python -m verification.water_and_loads seismic [--spacing H]

- ``strip``: ``studies/strip_load.toml`` (a strip footing on undrained clay) at several particle
  spacings against Prandtl's FOS = (2 + pi) cu / q;
- ``drawdown``: ``studies/drawdown.toml`` (Griffiths & Lane 1999, example 5) against their
  FOS at every L / H (``DRAWDOWN_REFERENCE``);
- ``seismic``: ``studies/seismic.toml`` (Loukidis et al. 2003) over kh: FOS falling with kh and
  FOS = 1 at the critical coefficient kc = 0.432.

Each prints a table; docs/verification.md quotes them.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import xarray as xr

from workflows.cases import RunOptions
from workflows.study import load_study, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
STUDIES = REPO / "studies"

DRAWDOWN_REFERENCE = {-0.2: 1.85, 0.0: 1.85, 0.2: 1.60, 0.4: 1.40, 0.5: 1.35, 0.7: 1.30, 0.9: 1.35, 1.0: 1.40}
"""Griffiths & Lane (1999) Fig. 15: FOS by L / H, read off to about +-0.05."""
SEISMIC_KC = 0.432
"""Loukidis et al. (2003): the kh at which FOS = 1 (log-spiral limit equilibrium)."""


def _with_spacing(path: Path, spacing_m: float | None):
    study = load_study(path)
    if spacing_m is None:
        return study
    return parse_study(study.source_text.replace(f"spacing_m = {study.geometry.spacing_m}", f"spacing_m = {spacing_m}"))


def prandtl_fos(study) -> float:
    """(2 + pi) cu / q of the strip-load study."""
    return (2.0 + math.pi) * study.materials[0].cohesion_pa / study.loads.strip[0].pressure_pa


def strip(out: Path, spacings: list[float], workers: int) -> None:
    print("strip footing on undrained clay: FOS against (2 + pi) cu / q")
    print(f"{'h (m)':>7}  {'particles':>9}  {'FOS':>7}  {'bracket':>17}  {'error':>7}")
    for spacing in spacings:
        study = _with_spacing(STUDIES / "strip_load.toml", spacing)
        outcome = run_study(study, out / f"strip_h{spacing:g}", RunOptions(workers=workers))
        exact = prandtl_fos(study)
        print(f"{spacing:7g}  {outcome.n_particles:9d}  {outcome.fos:7.4f}  [{outcome.fos_low:.4f}, "
              f"{outcome.fos_high:.4f}]  {100 * (outcome.fos / exact - 1):+6.2f}%   (Prandtl {exact:.4f})")


def drawdown(out: Path, spacing: float | None, workers: int) -> None:
    study = _with_spacing(STUDIES / "drawdown.toml", spacing)
    run_study(study, out / "drawdown", RunOptions(workers=workers))
    height = study.geometry.slope.height_m
    print(f"Griffiths & Lane (1999) example 5, h = {study.geometry.spacing_m:g} m: FOS against L / H")
    print(f"{'L / H':>6}  {'FOS':>7}  {'G&L':>5}  {'error':>7}")
    with xr.open_dataset(out / "drawdown" / "study.nc") as ds:
        levels = ds["phreatic_level_m"].values
        for i, level in enumerate(levels):
            ratio = round((height - float(level)) / height, 6)
            fos = float(ds["fos"].values[i])
            reference = DRAWDOWN_REFERENCE[ratio]
            print(f"{ratio:6.2f}  {fos:7.4f}  {reference:5.2f}  {100 * (fos / reference - 1):+6.1f}%")


def seismic(out: Path, spacing: float | None, workers: int) -> None:
    study = _with_spacing(STUDIES / "seismic.toml", spacing)
    run_study(study, out / "seismic", RunOptions(workers=workers))
    print(f"Loukidis et al. (2003), h = {study.geometry.spacing_m:g} m: FOS against kh (FOS = 1 at kc = {SEISMIC_KC})")
    with xr.open_dataset(out / "seismic" / "study.nc") as ds:
        kh = ds["horizontal_coefficient"].values
        fos = ds["fos"].values
        for value, f in zip(kh, fos):
            print(f"kh {float(value):5.3f}  FOS {float(f):.4f}")
    monotone = all(b < a for a, b in zip(fos[:-1], fos[1:]))
    print(f"falls monotonically with kh: {monotone}; FOS at kc: {float(fos[-1]):.4f} "
          f"({100 * (float(fos[-1]) - 1):+.1f}% from 1)")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m verification.water_and_loads", description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("strip", "drawdown", "seismic"))
    parser.add_argument("--spacings", type=float, nargs="+", default=[0.5, 0.25, 0.125],
                        help="strip: particle spacings (m)")
    parser.add_argument("--spacing", type=float, default=None, help="drawdown, seismic: particle spacing (m)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        if args.case == "strip":
            strip(out, args.spacings, args.workers)
        elif args.case == "drawdown":
            drawdown(out, args.spacing, args.workers)
        else:
            seismic(out, args.spacing, args.workers)


if __name__ == "__main__":
    main()
