"""Rain and drawdown studies (``[transient]``) against their limits and references.

    python -m verification.rain_and_drawdown drawdown [--workers 2] [--out DIR]
    python -m verification.rain_and_drawdown rain [--workers 2] [--out DIR]

- ``drawdown``: the slope of Griffiths & Lane (1999, example 5; ``studies/drawdown.toml``) drawn down
  from its crest to its toe (L / H = 0 to 1) in 48 h (``studies/drawdown_time.toml``).  At 24, 36 and
  48 h (L / H = 0.5, 0.75, 1): the slow-drawdown limit with the steady water of ``[water]`` (a line and a
  pond at the reservoir's level; Griffiths & Lane's Fig. 15), and the transient flow's FOS at very low
  (1e-9 m/s: nothing drains in 48 h, the rapid limit), the shipped (1e-6 m/s) and very high (1e-2 m/s:
  the water table follows the reservoir) permeability; then the shipped study's FOS against time.
- ``rain``: ``studies/rain.toml``: its FOS against time, the mass balance of its flow, the flow's
  share of the wall time and the runs per FOS.

Each prints a table; docs/verification.md quotes them.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

import xarray as xr

from workflows.cases import RunOptions
from workflows.study import load_study, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
STUDIES = REPO / "studies"
SLOW_REFERENCE = {0.5: 1.35, 1.0: 1.40}
"""Griffiths & Lane (1999) Fig. 15: the FOS of slow drawdown by L / H, read off to about +-0.05 (0.75: between
their 0.7 and 0.9, 1.30 and 1.35)."""
DRAWDOWN_TIMES_H = (24.0, 36.0, 48.0)
LIMIT_PERMEABILITIES_M_S = (1e-9, 1e-6, 1e-2)


def _steady(level_m: float):
    """``studies/drawdown.toml`` without its sweep: the slow-drawdown water, a line and a pond at one level."""
    text = (STUDIES / "drawdown.toml").read_text()
    text = text[:text.index("[sweep]")]
    text = re.sub(r"phreatic_level_m = [0-9.]+", f"phreatic_level_m = {level_m}", text)
    return parse_study(re.sub(r"pond_level_m = [0-9.]+", f"pond_level_m = {level_m}", text))


def _transient_at(time_h: float, permeability_m_s: float):
    """``studies/drawdown_time.toml`` with its water at ``time_h`` (one FOS), at a permeability."""
    text = load_study(STUDIES / "drawdown_time.toml").source_text
    text = re.sub(r"fos_times_h = \[[^\]]*\]", f"water_at_h = {time_h}", text)
    text = re.sub(r"permeability_m_s = [0-9.e+-]+", f"permeability_m_s = {permeability_m_s:g}", text)
    return parse_study(text.replace("srf_min = 0.6", "srf_min = 0.3"))


def drawdown(out: Path, workers: int) -> None:
    options = RunOptions(workers=workers)
    study = load_study(STUDIES / "drawdown_time.toml")
    height_m = study.geometry.slope.height_m
    print("Griffiths & Lane's slope drawn down from its crest to its toe in 48 h: the FOS during the drawdown")
    print(f"{'t (h)':>6}  {'L / H':>5}  {'slow: line':>10}  {'G&L slow':>8}  " + "  ".join(
        f"{f'k = {k:g}':>10}" for k in LIMIT_PERMEABILITIES_M_S))
    for time_h in DRAWDOWN_TIMES_H:
        level_m = study.transient.reservoir_level_m(time_h)
        ratio = round((height_m - level_m) / height_m, 6)
        slow = run_study(_steady(level_m), out / f"slow_{time_h:g}", options)
        transient = [run_study(_transient_at(time_h, k), out / f"t{time_h:g}_k{k:g}", options)
                     for k in LIMIT_PERMEABILITIES_M_S]
        print(f"{time_h:6g}  {ratio:5.2f}  {slow.fos:10.3f}  {SLOW_REFERENCE.get(ratio, float('nan')):8.2f}  "
              + "  ".join(f"{o.fos:10.3f}" for o in transient))
    start = time.perf_counter()
    against_time = run_study(study, out / "drawdown_time", options)
    _fos_time_table(out / "drawdown_time", against_time, time.perf_counter() - start)


def rain(out: Path, workers: int) -> None:
    start = time.perf_counter()
    outcome = run_study(load_study(STUDIES / "rain.toml"), out / "rain", RunOptions(workers=workers))
    _fos_time_table(out / "rain", outcome, time.perf_counter() - start)


def _fos_time_table(folder: Path, outcome, wall_s: float) -> None:
    """The FOS against time of a study, its flow's balance and cost."""
    with xr.open_dataset(folder / "fos_time.nc") as curve, xr.open_dataset(folder / "transient.nc") as flow:
        print(f"\n{folder.name}: FOS against time")
        print(f"{'t (h)':>7}  {'FOS':>6}  {'bracket':>17}  {'runs':>4}  {'rain (mm/h)':>11}  {'level (m)':>9}")
        for i, t in enumerate(curve["time"].values):
            print(f"{t:7.3g}  {float(curve['fos'][i]):6.3f}  [{float(curve['fos_low'][i]):.4g}, "
                  f"{float(curve['fos_high'][i]):.4g}]  {int(curve['runs'][i]):4d}  "
                  f"{float(curve['rain_intensity'][i]):11.3g}  {float(curve['reservoir_level'][i]):9.3g}")
        runs = curve["runs"].values
        print(f"time the FOS reaches 1: {curve.attrs['time_fos_one_h']:.3g} h; runs per FOS {runs.mean():.1f} "
              f"(the first {runs[0]}, the later ones in a predicted window {runs[1:].mean():.1f})")
        attrs = flow.attrs
        print(f"mass balance: water in {float(flow['water_in'][-1]):.4g} m2/m, out {float(flow['water_out'][-1]):.4g}, "
              f"stored {float(flow['stored_water'][-1] - flow['stored_water'][0]):+.4g}; closed to "
              f"{attrs['largest_balance_fraction']:.1e} (worst step {attrs['largest_step_balance_fraction']:.1e})")
        print(f"cost: the flow {attrs['wall_time_s']:.1f} s of {wall_s:.1f} s ({attrs['wall_time_s'] / wall_s:.1%}); "
              f"{outcome.timings_s['total']:.1f} s by the study's own clock")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("drawdown", "rain"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch)
        if args.case == "drawdown":
            drawdown(out, args.workers)
        else:
            rain(out, args.workers)


if __name__ == "__main__":
    main()
