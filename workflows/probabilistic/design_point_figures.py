"""Figures of a form, point_estimate or subset_simulation study (``workflows.probabilistic.design_points``), drawn from its
``probabilistic.nc`` (PNG, matplotlib without a display):

- ``form.png``: the FOS at each iteration's centre against the iteration, with the factor, and the
  sensitivity factors alpha as bars (alpha^2 the variable's share), beta, the FOSM index (and SORM's beta)
  and the design point in the titles;
- ``subset_simulation.png``: P(FOS < threshold) at each level's threshold down to pf at the factor (the
  curve of pf against the threshold), and the FOS of every level's samples, the last level's failures marked;
- ``point_estimate.png``: the FOS at the 2^n points (their weights as the markers' areas) with the mean
  and mean +- std of the estimate.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot, save_figure


def draw_form(out_dir: Path, ds: xr.Dataset, factor: float) -> Path:
    """``form.png`` (module doc), into ``out_dir``."""
    plt = pyplot()
    path = out_dir / "form.png"
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    iteration = ds["form_iteration"].values
    iterations = np.unique(iteration[iteration >= 0])  # (-1: SORM's points)
    centres = np.array([np.flatnonzero(iteration == k)[0] for k in iterations])
    left.plot(iterations, ds["fos"].values[centres], "o-", color="tab:blue", label="FOS at the centre")
    left.axhline(factor, color="tab:red", lw=1, label=f"factor {factor:g}")
    sorm = (f"; SORM {ds.attrs['reliability_index_sorm']:.3f}" if "reliability_index_sorm" in ds.attrs else "")
    left.set(xlabel="iteration", ylabel="FOS", title=f"beta = {ds.attrs['reliability_index_form']:.3f} "
             f"(FOSM {ds.attrs['reliability_index_fosm']:.3f}{sorm}), pf_FORM {ds.attrs['pf_form']:.3g}")
    left.legend()
    labels = [str(label) for label in ds["random_variable"].values]
    right.barh(labels, ds["sensitivity_alpha"].values, color="tab:gray")
    right.axvline(0.0, color="black", lw=0.5)
    right.set(xlabel="sensitivity alpha", title="design point: " + ", ".join(
        f"{label} {value:.4g}" for label, value in zip(labels, ds["design_point"].values)))
    right.title.set_fontsize(8)
    return _saved(plt, fig, path)


def draw_subset_simulation(out_dir: Path, ds: xr.Dataset, factor: float) -> Path:
    """``subset_simulation.png`` (module doc), into ``out_dir``."""
    plt = pyplot()
    path = out_dir / "subset_simulation.png"
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    left.semilogy(ds["threshold_fos"].values, ds["threshold_pf"].values, "o-", color="tab:blue")
    left.axvline(factor, color="tab:red", lw=1, label=f"factor {factor:g}")
    left.set(xlabel="threshold FOS", ylabel="P(FOS < threshold)",
             title=f"pf = {ds.attrs['pf']:.3g}, cov {ds.attrs['pf_cov']:.3g}")
    left.legend()
    level, fos = ds["subset_level"].values, ds["fos"].values
    sample = ds["subset_accepted"].values == 1
    right.scatter(level[sample], fos[sample], s=6, color="tab:gray", label="levels' samples")
    failed = ds["last_level_failed"].values == 1
    right.scatter(level[failed], fos[failed], s=10, color="tab:red", label="last level below the factor")
    right.axhline(factor, color="tab:red", lw=1)
    right.set(xlabel="level", ylabel="FOS", title="the points by level")
    right.legend(fontsize=8)
    return _saved(plt, fig, path)


def draw_point_estimate(out_dir: Path, ds: xr.Dataset, factor: float) -> Path:
    """``point_estimate.png`` (module doc), into ``out_dir``."""
    plt = pyplot()
    path = out_dir / "point_estimate.png"
    fig, ax = plt.subplots(figsize=(6, 4))
    fos, weights = ds["fos"].values, ds["point_weight"].values
    ax.scatter(np.arange(fos.size), fos, s=400 * weights / weights.max(), color="tab:blue", label="points")
    mean, std = ds.attrs["point_estimate_fos_mean"], ds.attrs["point_estimate_fos_std"]
    ax.axhline(mean, color="tab:green", label=f"mean {mean:.4g}")
    ax.axhspan(mean - std, mean + std, color="tab:green", alpha=0.2, label=f"+- std {std:.3g}")
    ax.axhline(factor, color="tab:red", lw=1, label=f"factor {factor:g}")
    ax.set(xlabel="point", ylabel="FOS", title=f"point estimate: beta {ds.attrs['reliability_index_normal']:.3f} "
           f"(normal FOS), {ds.attrs['reliability_index_lognormal']:.3f} (lognormal)")
    ax.legend(fontsize=8)
    return _saved(plt, fig, path)


def _saved(plt, fig, path: Path) -> Path:
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
