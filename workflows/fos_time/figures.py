"""``fos_time.png``: the FOS against time above the rain (or the reservoir's level) that drove it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from workflows.output.figures import pyplot, save_figure
from workflows.transient.results import rain_mm_h, reservoir_level_m

FIGURE_NAME = "fos_time.png"
HISTORY_SAMPLES = 800
"""Points at which the rain or the level is drawn over the flow's duration."""


def draw_fos_time(study, dataset, flow, out_dir: Path) -> Path:
    """The FOS with its bracket at each time (1 dashed), and under it the rain intensity (mm/h) or the
    reservoir's level (m) over the whole flow, on one time axis."""
    plt = pyplot()
    end_h = study.transient.end_time_h
    times = dataset["time"].values
    fos = dataset["fos"].values
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 5.5), sharex=True, height_ratios=(2, 1))
    top.errorbar(times, fos, yerr=[fos - dataset["fos_low"].values, dataset["fos_high"].values - fos], fmt="o-",
                 color="tab:blue", capsize=3, lw=1.2, ms=4, label="FOS (strength reduction, bracket)")
    top.axhline(1.0, color="tab:red", ls="--", lw=1.0)
    one = float(dataset.attrs.get("time_fos_one_h", np.nan))
    if np.isfinite(one):
        top.axvline(one, color="tab:red", ls=":", lw=1.0, label=f"FOS = 1 at {one:.3g} h")
    top.set_ylabel("FOS")
    top.legend(fontsize=8)
    top.grid(alpha=0.3)
    top.set_title(f"{study.name}: factor of safety against time")
    grid = np.linspace(0.0, end_h, HISTORY_SAMPLES)
    level = reservoir_level_m(flow, grid)
    if np.all(np.isnan(level)):
        flux = rain_mm_h(flow, grid)
        bottom.fill_between(grid, flux, step="post", color="tab:cyan", alpha=0.7)
        bottom.set_ylabel("rain less evaporation (mm/h)" if np.any(flux < 0.0) else "rain (mm/h)")
    else:
        bottom.plot(grid, level, color="tab:blue", lw=1.5)
        bottom.set_ylabel("reservoir level (m)")
    bottom.set_xlabel("time (h)")
    bottom.set_xlim(0.0, end_h)
    bottom.grid(alpha=0.3)
    fig.tight_layout()
    path = save_figure(fig, Path(out_dir) / FIGURE_NAME, dpi=120)
    plt.close(fig)
    return path
