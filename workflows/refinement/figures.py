"""``convergence.png`` of a refinement study: each level's FOS and bracket against its spacing h,
the fit of the band's procedure through them to h -> 0 and the band there (PNG, matplotlib without
a display, ``workflows.output.figures``)."""

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
    if math.isfinite(ds.attrs["repeat_fos"]):
        ax.plot([h[1]], [ds.attrs["repeat_fos"]], "x", color="tab:blue", label="level 1, another jitter seed")
    band_low, band_high = ds.attrs["band_low"], ds.attrs["band_high"]
    if math.isfinite(band_low):
        trusted = "trusted" if ds.attrs["band_trusted"] else "not to be trusted"
        ax.fill_between([0.0, 0.04 * h.max()], band_low, band_high, color="tab:orange", alpha=0.3,
                        label=f"FOS at h -> 0, 95% band ({trusted})")
        limit = float(ds["fos_limit"])
        fit = ds["fos_fit"].values
        order = np.argsort(h)
        ax.plot(np.concatenate([[0.0], h[order]]), np.concatenate([[limit], fit[order]]), "--", color="tab:orange",
                label=f"fit: {ds.attrs['fit_kind']}")
        ax.plot([0.0], [limit], "s", color="tab:orange")
    ax.set_xlim(left=0.0)
    ax.set_xlabel("particle spacing h (m)" + (" of the band" if ds.attrs["mode"] == "adaptive" else ""))
    ax.set_ylabel("factor of safety")
    ax.set_title(f"{ds.attrs['study_name']}: FOS against particle spacing", fontsize=10)
    ax.legend(fontsize=8)
    path = Path(out_dir) / "convergence.png"
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return [path]
