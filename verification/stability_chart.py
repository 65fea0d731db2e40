"""Sweeps against stability charts: Taylor's (1937) phi = 0 chart, and FOS proportional to cu.

    python -m verification.stability_chart [--out DIR] [--workers N] [--foundation-depth D] [--spacing H]

1. ``studies/published/taylor_phi0.toml``: a 5 m slope of undrained clay on a firm base at the
   toe (D = 1), cu = 20 kPa, gamma = 20 kN/m3, swept over the face angle.  Steeper than 53 deg
   the critical circle passes through the toe whatever D, with Taylor's stability numbers
   ``TAYLOR_N``; spfem-fos gives N = cu / (F gamma H).
2. The same slope at 60 deg swept over cu (``CU_VALUES_PA``): with phi = 0 a run of cu at F
   and a run of k cu at k F are the same problem, so F / cu is one number; what differs between
   the cases is the resolution of each FOS bracket (``fos_tolerance``).

``--foundation-depth 0.5`` runs the chart on a foundation 0.5 H deep instead, ``--spacing``
at another particle spacing (m); either prints the chart table only.  On a foundation the toe
is a re-entrant corner, and the circle may pass below it.

Prints a table of each; the test suite asserts the bands (tests/test_sweep.py).
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from workflows.cases import RunOptions
from workflows.study import load_study, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
TAYLOR_STUDY = REPO / "studies" / "published" / "taylor_phi0.toml"

TAYLOR_N = {53.0: 0.181, 60.0: 0.191, 75.0: 0.219, 90.0: 0.261}
"""Taylor (1937): N = cu / (F gamma H) of phi = 0 slopes steeper than 53 deg (toe circles)."""
TAYLOR_BAND = 0.03
"""The chart values are reproduced within this relative error."""

CU_VALUES_PA = (15e3, 20e3, 25e3, 30e3)
CU_BAND = 0.01
"""max(F / cu) / min(F / cu) - 1 stays below this."""


@dataclass(frozen=True)
class ChartPoint:
    angle_deg: float
    fos: float
    n: float  # cu / (F gamma H)
    chart_n: float

    @property
    def error(self) -> float:
        return self.n / self.chart_n - 1.0


def _unit_weight_height(study) -> tuple[float, float]:
    clay = study.materials[0]
    return clay.density_kg_m3 * abs(study.loads.gravity_m_s2[1]), study.geometry.slope.height_m


def taylor_points(out_dir: Path, workers: int = 2, foundation_depth: float = 0.0,
                  spacing_m: float | None = None) -> list[ChartPoint]:
    """Run the Taylor sweep into ``out_dir``, with a foundation ``foundation_depth`` H deep and
    (if given) particle spacing ``spacing_m``; one point per angle."""
    study = load_study(TAYLOR_STUDY)
    text = study.source_text.replace("foundation_depth_m = 0.0",
                                     f"foundation_depth_m = {foundation_depth * study.geometry.slope.height_m}")
    if spacing_m is not None:
        text = text.replace(f"spacing_m = {study.geometry.spacing_m}", f"spacing_m = {spacing_m}")
    study = parse_study(text)
    run_study(study, out_dir, RunOptions(workers=workers))
    gamma, height = _unit_weight_height(study)
    cu = study.materials[0].cohesion_pa
    with xr.open_dataset(out_dir / "study.nc") as ds:
        return [ChartPoint(angle, float(ds["fos"].sel(angle_deg=angle)),
                           cu / (float(ds["fos"].sel(angle_deg=angle)) * gamma * height), chart)
                for angle, chart in TAYLOR_N.items()]


def cu_study_text() -> str:
    """The Taylor study at 60 deg, swept over cu instead of the angle."""
    head = TAYLOR_STUDY.read_text().split("[sweep]")[0]
    values = ", ".join(f"{cu:g}" for cu in CU_VALUES_PA)
    return f'{head}[sweep]\n[[sweep.axes]]\npath = "materials.clay.cohesion_pa"\nvalues = [{values}]\n'


def fos_per_cu(out_dir: Path, workers: int = 2) -> dict[float, float]:
    """Run the cu sweep into ``out_dir``; F / cu (1/kPa) by cu (Pa)."""
    run_study(parse_study(cu_study_text()), out_dir, RunOptions(workers=workers))
    with xr.open_dataset(out_dir / "study.nc") as ds:
        return {float(cu): float(ds["fos"].sel(cohesion_pa=cu)) / (cu / 1e3) for cu in ds["cohesion_pa"].values}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m verification.stability_chart", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--foundation-depth", type=float, default=0.0, metavar="D",
                        help="depth of a foundation below the toe, in slope heights (default 0: base at the toe)")
    parser.add_argument("--spacing", type=float, default=None, metavar="H", help="particle spacing (m), default the study's")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        points = taylor_points(out / "taylor", args.workers, args.foundation_depth, args.spacing)
        spacing_m = args.spacing or load_study(TAYLOR_STUDY).geometry.spacing_m
        print(f"Taylor (1937), phi = 0, D = {1 + args.foundation_depth:g}, h = {spacing_m:g} m: N = cu / (F gamma H)")
        print(f"{'angle (deg)':>11}  {'FOS':>7}  {'N':>7}  {'Taylor N':>8}  {'error':>7}")
        for p in points:
            print(f"{p.angle_deg:11g}  {p.fos:7.4f}  {p.n:7.4f}  {p.chart_n:8.3f}  {100 * p.error:+6.1f}%")
        if args.foundation_depth or args.spacing is not None:
            return
        ratios = fos_per_cu(out / "cu", args.workers)
        print("\nphi = 0, 60 deg: F / cu")
        for cu, ratio in ratios.items():
            print(f"cu {cu / 1e3:5g} kPa  F / cu = {ratio:.5f} per kPa")
        spread = max(ratios.values()) / min(ratios.values()) - 1.0
        print(f"spread max / min - 1 = {100 * spread:.2f}% (band {100 * CU_BAND:g}%)")


if __name__ == "__main__":
    main()
