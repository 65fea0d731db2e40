"""The cost of a study of the FOS against time: the transient flow's share of its wall time, and the
runs per FOS with the windows predicted from the times before against a full search at each time.

    python -m benchmarks.bench_rain [--study rain] [--skip-full]

The study (``studies/<study>.toml``) runs as a user runs it (``python -m workflows.cli``, 2 local
workers, the numba cache on disk): its wall time, the flow's (``transient.nc`` attribute
``wall_time_s``) and the runs of each time (``fos_time.nc``).  Then each of its times as a study of
its own (``water_at_h``, no window: the full search from srf_min), the same FOS within the search's
tolerance, and the runs it took.  Quote the load average with the numbers (2 shared cores).
"""

from __future__ import annotations

import argparse
import os
import re
import tempfile
from pathlib import Path

import xarray as xr

from verification.study_command import run_study_command

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", default="rain")
    parser.add_argument("--skip-full", action="store_true", help="leave out the full search at each time")
    args = parser.parse_args(argv)
    text = (ROOT / "studies" / f"{args.study}.toml").read_text()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as scratch:
        out, wall_s = run_study_command(text, Path(scratch) / "against_time")
        with xr.open_dataset(out / "transient.nc") as flow, xr.open_dataset(out / "fos_time.nc") as curve:
            flow_s = float(flow.attrs["wall_time_s"])
            times, fos, runs = curve["time"].values, curve["fos"].values, curve["runs"].values
        print(f"{args.study}: {len(times)} times, wall time {wall_s:.1f} s, the flow {flow_s:.2f} s "
              f"({flow_s / wall_s:.1%}); runs per FOS {runs.mean():.1f} (first {runs[0]}, then {runs[1:].mean():.1f} "
              "in predicted windows)")
        print(f"load average after: {os.getloadavg()[0]:.2f}")
        if args.skip_full:
            return
        print(f"{'t (h)':>7}  {'FOS (windows)':>13}  {'runs':>4}  {'FOS (full search)':>17}  {'runs':>4}")
        full_runs = []
        single = re.sub(r"fos_interval_h = [0-9.]+\n|fos_times_h = \[[^\]]*\]\n", "", text)
        single = single.replace("stop_below_fos = 1.0\n", "").replace("runout_duration_s = 5.0\n", "")
        for t, f, r in zip(times, fos, runs):
            out_t, _ = run_study_command(single.replace("[transient]\n", f"[transient]\nwater_at_h = {t}\n"),
                                         Path(scratch) / f"t{t:g}")
            with xr.open_dataset(out_t / "summary.nc") as summary:
                full_fos, n = float(summary["fos"]), int(summary.sizes["srf"])
            full_runs.append(n)
            print(f"{t:7.3g}  {f:13.4f}  {r:4d}  {full_fos:17.4f}  {n:4d}")
        print(f"runs per FOS: {runs.mean():.1f} with predicted windows, {sum(full_runs) / len(full_runs):.1f} with full "
              f"searches; load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
