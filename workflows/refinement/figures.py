"""``convergence.png`` of a refinement study: each level's FOS and bracket against its spacing h,
the extrapolation to h -> 0 (f_ext + (f1 - f_ext) (h / h1)^p through the finest level) and the
discretisation band at h = 0 (PNG, matplotlib without a display, ``workflows.output.figures``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot, save_figure


def draw_convergence(out_dir: Path, ds: xr.Dataset) -> list[Path]:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.12, top=0.9)
    h = ds["spacing"].values
    fos, low, high = ds["fos"].values, ds["fos_low"].values, ds["fos_high"].values
    found = np.isfinite(fos)
    ax.errorbar(h[found], fos[found], yerr=[fos[found] - low[found], high[found] - fos[found]], fmt="o",
                color="tab:blue", capsize=3, label="FOS and bracket per level")
    status = ds.attrs["extrapolation_status"]
    band_low, band_high = ds.attrs["band_low"], ds.attrs["band_high"]
    if math.isfinite(band_low):
        ax.fill_between([0.0, 0.04 * h.max()], band_low, band_high, color="tab:orange", alpha=0.3,
                        label=f"band at h -> 0 ({status.replace('_', ' ')})")
    p, extrapolated = ds.attrs["observed_order"], float(ds["fos_extrapolated"])
    if status == "extrapolated":
        finest = int(np.argmin(np.where(found, h, np.inf)))
        curve_h = np.linspace(0.0, h[found].max(), 100)
        curve = extrapolated + (fos[finest] - extrapolated) * (curve_h / h[finest]) ** p
        ax.plot(curve_h, curve, "--", color="tab:orange", label=f"Richardson, p = {p:.2g}")
        ax.plot([0.0], [extrapolated], "s", color="tab:orange")
    ax.set_xlim(left=0.0)
    ax.set_xlabel("particle spacing h (m)")
    ax.set_ylabel("factor of safety")
    ax.set_title(f"{ds.attrs['study_name']}: FOS against particle spacing", fontsize=10)
    ax.legend(fontsize=8)
    path = Path(out_dir) / "convergence.png"
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return [path]
