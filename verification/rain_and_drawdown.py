"""Rain and drawdown studies (``[transient]``) against their limits and references.

    python -m verification.rain_and_drawdown drawdown [--workers 2] [--out DIR]
    python -m verification.rain_and_drawdown rain [--workers 2] [--out DIR]
    python -m verification.rain_and_drawdown rapid [--workers 2] [--out DIR]
    python -m verification.rain_and_drawdown suction [--workers 2] [--out DIR]

- ``drawdown``: the slope of Griffiths & Lane (1999, example 5; ``studies/drawdown.toml``) drawn down
  from its crest to its toe (L / H = 0 to 1) in 48 h (``studies/drawdown_time.toml``).  At 24, 36 and
  48 h (L / H = 0.5, 0.75, 1): the slow-drawdown limit with the steady water of ``[water]`` (a line and a
  pond at the reservoir's level; Griffiths & Lane's Fig. 15), and the transient flow's FOS at very low
  (1e-9 m/s: nothing drains in 48 h, the rapid limit), the shipped (1e-6 m/s) and very high (1e-2 m/s:
  the water table follows the reservoir) permeability; then the shipped study's FOS against time.
- ``rapid``: the rapid-drawdown limit of the same slope at L / H = 0, 0.25, 0.5, 0.75, 1 (:func:`rapid_line`: the
  pore pressures of the full reservoir less the unloading, B-bar = 1), beside the transient flow at very low
  permeability at the same levels and, where no water stands on the slope (L / H = 1), Bishop's least circle on
  the same pore pressures (``workflows.fos.critical_circle``).
- ``suction``: the slope of ``studies/rain.toml`` in Gardner's soil over a water table at its base, under steady
  rain q = 0, 0.01, 0.1, 0.5, 0.9 K_s: the particles' pressure head and suction stress under the crest (far from the
  face, where the flow is vertical) against Lu & Griffiths' (2004) closed form, and the FOS with that suction.
- ``rain``: ``studies/rain.toml``: its FOS against time, the mass balance of its flow, the flow's
  share of the wall time and the runs per FOS.

Each prints a table; docs/verification.md quotes them.
"""

from __future__ import annotations

import argparse
import math
import re
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.geometry import surface_height_m
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
RAPID_RATIOS = (0.0, 0.25, 0.5, 0.75, 1.0)
"""L / H of Lane & Griffiths' (2000) rapid-drawdown charts at which the limit is computed."""


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


def rapid_line(polygon_m, height_m: float, level_m: float) -> list[list[float]]:
    """The piezometric line of rapid drawdown from a full reservoir at the crest (``height_m``) to ``level_m``:
    the ground surface where it lies above the level, the level elsewhere, so u = gamma_w (max(L, y_s(x)) - y).

    Undrained unloading with B-bar = 1 (Skempton's pore-pressure coefficient; the rapid case of Morgenstern's
    1963 charts): removing the water that stood above a point of the face lowers the total stress of the soil
    below it by gamma_w times that water's depth, and its pore pressure by as much.  The full state's
    u = gamma_w (H - y) less gamma_w (H - max(L, y_s)) leaves gamma_w (max(L, y_s) - y): hydrostatic from the
    uncovered face (zero on it), from the new level where water still stands, and the full reservoir's under
    the crest, where no load was removed."""
    polygon = np.asarray(polygon_m, dtype=float)
    x = np.unique(polygon[:, 0])  # the surface is straight between its vertices' abscissae
    ground_m = surface_height_m(polygon, x)
    above = ground_m - level_m
    crossings = [x[i] + (x[i + 1] - x[i]) * above[i] / (above[i] - above[i + 1])
                 for i in range(x.size - 1) if above[i] * above[i + 1] < 0.0]
    x = np.unique(np.concatenate([x, crossings]))
    ground_m = surface_height_m(polygon, x)
    line_m = np.minimum(np.maximum(ground_m, level_m), height_m)
    return [[float(a), float(b)] for a, b in zip(x, line_m)]


def _rapid(level_m: float):
    """``studies/drawdown.toml`` without its sweep, its water the rapid-drawdown line (:func:`rapid_line`) and a
    pond at the reservoir's level."""
    text = (STUDIES / "drawdown.toml").read_text()
    text = text[:text.index("[sweep]")]
    study = parse_study(text)
    line = rapid_line(study.geometry.polygon_m, study.geometry.slope.height_m, level_m)
    text = re.sub(r"phreatic_level_m = [0-9.]+", f"phreatic_line_m = {line}", text)
    text = re.sub(r"pond_level_m = [0-9.]+", f"pond_level_m = {level_m}", text)
    return parse_study(text.replace("srf_min = 1.0", "srf_min = 0.3"))


def rapid(out: Path, workers: int) -> None:
    """The rapid-drawdown limit (:func:`rapid_line`) against the slow one and the transient flow at 1e-9 m/s."""
    from workflows.fos.critical_circle import critical_circle

    options = RunOptions(workers=workers)
    transient = load_study(STUDIES / "drawdown_time.toml").transient
    height_m = 10.0
    print("Griffiths & Lane's slope (cot beta = 2, phi' = 20 deg, c' / gamma H = 0.05): rapid drawdown from the crest")
    print(f"{'L / H':>5}  {'rapid (B = 1)':>13}  {'bracket':>17}  {'Bishop, same u':>14}  {'slow: line':>10}  "
          f"{'k = 1e-9, t (h)':>15}")
    for ratio in RAPID_RATIOS:
        level_m = height_m * (1.0 - ratio)
        study = _rapid(level_m)
        outcome = run_study(study, out / f"rapid_{ratio:g}", options)
        circle = critical_circle(study) if level_m <= 0.0 else None  # (its water has no pond)
        slow = run_study(_steady(level_m), out / f"slow_{ratio:g}", options)
        time_h = next(t for t in np.linspace(0.0, 48.0, 193) if transient.reservoir_level_m(t) <= level_m + 1e-9)
        low_k = run_study(_transient_at(float(time_h), 1e-9), out / f"t{time_h:g}_k1e-9", options)
        low = f"{low_k.fos:.3f}" if math.isfinite(low_k.fos) else f"< {low_k.fos_high:.3g}"
        print(f"{ratio:5.2f}  {outcome.fos:13.3f}  [{outcome.fos_low:.4g}, {outcome.fos_high:.4g}]  "
              f"{(f'{circle.fos:.3f}' if circle is not None else '-'):>14}  {slow.fos:10.3f}  "
              f"{low:>8} ({time_h:g})")


SUCTION_RATIOS = (0.0, 0.01, 0.1, 0.5, 0.9)
"""q / K_s of the steady rain of ``suction``."""
SUCTION_END_H = 4000.0
"""The steady state: the flow followed this long (the change over its last saved interval is printed)."""
SUCTION_COLUMN_X_M = 2.0
"""The crest's particles at x <= this (the crest ends at x = 20 m) are compared with the vertical flow."""


def _suction_study(rain_mm_h: float):
    """``studies/rain.toml`` in Gardner's soil (alpha 0.5 /m), its water table at its base (held at psi = 0 there,
    no flow through its sides), steady rain of ``rain_mm_h``, its water at ``SUCTION_END_H``."""
    text = (STUDIES / "rain.toml").read_text()
    for old, new in (('model = "van_genuchten"', 'model = "gardner"'), ("n = 2.0\n", ""),
                     ("initial_water_table_m = 3.0", "initial_water_table_m = 0.0"), ("suction_limit_m = 5.0\n", ""),
                     ("end_time_h = 48.0", f"end_time_h = {SUCTION_END_H}\nmax_step_h = 100.0"),
                     ("fos_interval_h = 6.0\nstop_below_fos = 1.0\nrunout_duration_s = 5.0",
                      f"water_at_h = {SUCTION_END_H}"),
                     ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]", f"rain_mm_h = {rain_mm_h}"),
                     ('name = "far_side"\ncondition = "total_head"\nx_min_m = 60.0\ntotal_head_m = 3.0',
                      'name = "water_table"\ncondition = "pressure_head"\ny_max_m = 0.0\npressure_head_m = 0.0')):
        assert old in text, old
        text = text.replace(old, new)
    return parse_study(text)


def lu_griffiths_pressure_head_m(height_m, ratio: float, alpha_1_m: float):
    """Lu & Griffiths (2004), Gardner's soil, a steady downward flux q = ratio K_s at ``height_m`` above the water
    table: psi = ln(q / K_s + (1 - q / K_s) exp(-alpha z)) / alpha."""
    return np.log(ratio + (1.0 - ratio) * np.exp(-alpha_1_m * np.asarray(height_m))) / alpha_1_m


def suction(out: Path, workers: int) -> None:
    """The suction stress under the crest against Lu & Griffiths' closed form, and the FOS with it."""
    from workflows.transient.flow import transient_flow  # the core's mesh (numba): on use

    options = RunOptions(workers=workers)
    print("The rain slope in Gardner's soil (alpha 0.5 /m, K_s 1e-5 m/s), water table at its base, steady rain q;")
    print(f"under the crest (x <= {SUCTION_COLUMN_X_M:g} m, 15 m above the water table) against Lu & Griffiths (2004)")
    print(f"{'q / K_s':>7}  {'mm/h':>5}  {'psi top: exact':>14}  {'computed':>8}  {'max |dpsi| (m)':>14}  "
          f"{'sigma_s top (kPa)':>17}  {'max |dsigma_s| (kPa)':>20}  {'last change (m)':>15}  {'FOS':>6}")
    for ratio in SUCTION_RATIOS:
        study = _suction_study(ratio * study_permeability_mm_h())
        curve = study.transient.curves[0]
        flow = transient_flow(study)
        water = flow.water_at(SUCTION_END_H)
        x, y = water.node_xy_m[:, 0], water.node_xy_m[:, 1]
        column = x <= SUCTION_COLUMN_X_M + 1e-9
        exact = lu_griffiths_pressure_head_m(y[column], ratio, curve.alpha_1_m)
        stress = water.pore_pressure_pa()[column] / 1e3
        stress_exact = water.water_unit_weight_n_m3 * np.exp(curve.alpha_1_m * np.minimum(exact, 0.0)) * exact / 1e3
        psi = water.pressure_head_m[column]
        top = np.argmax(y[column])
        heads = flow.solution.head_m
        change = float(np.max(np.abs(heads[-1] - heads[-2])))
        outcome = run_study(study, out / f"suction_{ratio:g}", options)
        print(f"{ratio:7g}  {ratio * study_permeability_mm_h():5.3g}  {exact[top]:14.3f}  {psi[top]:8.3f}  "
              f"{np.max(np.abs(psi - exact)):14.2e}  {stress_exact[top]:17.3f}  "
              f"{np.max(np.abs(stress - stress_exact)):20.2e}  {change:15.1e}  {outcome.fos:6.3f}")


def study_permeability_mm_h() -> float:
    """K_s of ``studies/rain.toml``'s soil in mm/h."""
    return 1e-5 * 3.6e6


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
    parser.add_argument("case", choices=("drawdown", "rain", "rapid", "suction"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch)
        if args.case == "drawdown":
            drawdown(out, args.workers)
        elif args.case == "rapid":
            rapid(out, args.workers)
        elif args.case == "suction":
            suction(out, args.workers)
        else:
            rain(out, args.workers)


if __name__ == "__main__":
    main()
