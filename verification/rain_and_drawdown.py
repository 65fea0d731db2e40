"""Rain and drawdown studies (``[transient]``) against their limits and references.

    python -m verification.rain_and_drawdown drawdown [--workers 2] [--out DIR]
    python -m verification.rain_and_drawdown rain [--workers 2] [--out DIR]

- ``drawdown``: the slope of Griffiths & Lane (1999, example 5; ``studies/drawdown.toml``) drawn down
  from its crest to its toe (L / H = 0 to 1) in 48 h (``studies/drawdown_time.toml``).  The two limits,
  each with the steady water of ``[water]`` (a drawn line, no flow):

  - *slow*: the water inside the slope at the reservoir's level, L / H = 1 (Griffiths & Lane's Fig. 15:
    1.40, read off to about +-0.05);
  - *rapid*: the water inside the slope still at the crest while the reservoir is gone (the rapid-
    drawdown case of Lane & Griffiths 2000: the phreatic surface stays, the external water is removed);

  and the transient flow's FOS at the end of the drawdown at very low (1e-9 m/s: nothing drains in
  48 h) and very high (1e-2 m/s: the water table follows the reservoir) permeability, which must reach
  the rapid and the slow limit, and at 1e-6 m/s, between them; then the shipped study's FOS against
  time at 1e-6 m/s.
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
SLOW_REFERENCE_L_H_1 = 1.40
"""Griffiths & Lane (1999) Fig. 15: the FOS of slow drawdown at L / H = 1, read off to about +-0.05."""
END_OF_DRAWDOWN_H = 48.0
LIMIT_PERMEABILITIES_M_S = (1e-9, 1e-6, 1e-2)


def _steady(phreatic_level_m: float, pond_level_m: float):
    """``studies/drawdown.toml`` without its sweep: the drawn water at one level inside and one outside."""
    text = (STUDIES / "drawdown.toml").read_text()
    text = text[:text.index("[sweep]")]
    text = re.sub(r"phreatic_level_m = [0-9.]+", f"phreatic_level_m = {phreatic_level_m}", text)
    text = re.sub(r"pond_level_m = [0-9.]+", f"pond_level_m = {pond_level_m}", text)
    return parse_study(text)


def _at_end_of_drawdown(permeability_m_s: float):
    """``studies/drawdown_time.toml`` with its water at the end of the drawdown (one FOS), at a permeability."""
    text = load_study(STUDIES / "drawdown_time.toml").source_text
    text = re.sub(r"fos_times_h = \[[^\]]*\]", f"water_at_h = {END_OF_DRAWDOWN_H}", text)
    text = re.sub(r"permeability_m_s = [0-9.e+-]+", f"permeability_m_s = {permeability_m_s:g}", text)
    return parse_study(text)


def drawdown(out: Path, workers: int) -> None:
    options = RunOptions(workers=workers)
    slow = run_study(_steady(0.0, 0.0), out / "slow", options)
    rapid = run_study(_steady(10.0, 0.0), out / "rapid", options)
    print("Griffiths & Lane's slope drawn down from L / H = 0 to 1: the FOS at L / H = 1")
    print(f"{'water':<44}  {'FOS':>6}  {'bracket':>17}")
    print(f"{'slow limit (line at the toe, no reservoir)':<44}  {slow.fos:6.3f}  [{slow.fos_low:.4g}, "
          f"{slow.fos_high:.4g}]   (Griffiths & Lane 1999: {SLOW_REFERENCE_L_H_1:.2f} +- 0.05)")
    print(f"{'rapid limit (line at the crest, no reservoir)':<44}  {rapid.fos:6.3f}  [{rapid.fos_low:.4g}, "
          f"{rapid.fos_high:.4g}]")
    for k in LIMIT_PERMEABILITIES_M_S:
        outcome = run_study(_at_end_of_drawdown(k), out / f"k_{k:g}", options)
        print(f"{f'transient, k = {k:g} m/s, after 48 h of drawdown':<44}  {outcome.fos:6.3f}  "
              f"[{outcome.fos_low:.4g}, {outcome.fos_high:.4g}]")
    start = time.perf_counter()
    against_time = run_study(load_study(STUDIES / "drawdown_time.toml"), out / "drawdown_time", options)
    wall_s = time.perf_counter() - start
    _fos_time_table(out / "drawdown_time", against_time, wall_s)


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
