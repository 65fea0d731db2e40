"""Figures of a probabilistic study, drawn from ``probabilistic.nc`` or a sweep's ``study.nc``
(PNG, matplotlib without a display).

- ``pf_convergence.png``: pf of the first n realisations against n, with its exact 95% interval
  (Clopper-Pearson, ``reliability.failure_probability``) as a band;
- ``fos_distribution.png`` (fos mode): the histogram of the realisations' FOS and their empirical
  CDF, the factor the study judges at and pf marked;
- ``sensitivity.png`` (fos mode, random variables): each variable's rank correlation with the FOS;
- ``pf.png`` of a sweep: pf with its interval against the first axis, one line per value of a
  second.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot
from workflows.probabilistic.reliability import failure_probability


def draw_probabilistic_figures(out_dir: Path, ds: xr.Dataset) -> list[Path]:
    """Every figure of one probabilistic study that its dataset supports (module doc)."""
    paths = [pf_convergence(out_dir / "pf_convergence.png", ds)]
    fos = ds["fos"].values
    if ds.attrs["compute"] == "fos" and np.isfinite(fos).sum() >= 3:
        paths.append(fos_distribution(out_dir / "fos_distribution.png", ds))
        if "fos_rank_correlation" in ds:
            paths.append(sensitivity(out_dir / "sensitivity.png", ds))
    return paths


def pf_convergence(path: Path, ds: xr.Dataset) -> Path:
    verdict = ds["verdict"].values
    decided = np.cumsum(verdict != "undecided")
    failed = np.cumsum(verdict == "failed")
    n, pf, low, high = [], [], [], []
    for k, f in zip(decided, failed):
        if k:
            estimate = failure_probability(int(f), int(k))
            n.append(k), pf.append(estimate[0]), low.append(estimate[1]), high.append(estimate[2])
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.fill_between(n, low, high, color="tab:blue", alpha=0.25, label="95% interval")
    ax.plot(n, pf, color="tab:blue", label="pf")
    ax.set(xlabel="realisations", ylabel="probability of failure", ylim=(0, 1),
           title=f"{ds.attrs['study_name']}: pf = {ds.attrs['pf']:.3g} [{ds.attrs['pf_low']:.3g}, "
                 f"{ds.attrs['pf_high']:.3g}]")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def fos_distribution(path: Path, ds: xr.Dataset) -> Path:
    fos = np.sort(ds["fos"].values[np.isfinite(ds["fos"].values)])
    factor = ds.attrs["factor"]
    plt = pyplot()
    fig, (hist, cdf) = plt.subplots(1, 2, figsize=(10, 4))
    hist.hist(fos, bins=max(5, int(np.sqrt(fos.size))), color="tab:gray")
    hist.set(xlabel="FOS", ylabel="realisations", title=f"mean {fos.mean():.3g}, std {fos.std(ddof=1):.3g}")
    cdf.step(fos, np.arange(1, fos.size + 1) / fos.size, where="post", color="tab:blue")
    cdf.set(xlabel="FOS", ylabel="P(FOS <= x)", title=f"pf = P(FOS < {factor:g}) = {ds.attrs['pf']:.3g}")
    for ax in (hist, cdf):
        ax.axvline(factor, color="tab:red", linestyle="--")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def sensitivity(path: Path, ds: xr.Dataset) -> Path:
    names = [str(name) for name in ds["random_variable"].values]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 0.6 * len(names) + 1.5))
    ax.barh(names, ds["fos_rank_correlation"].values, color="tab:blue")
    ax.axvline(0.0, color="black", linewidth=0.8)
    ax.set(xlabel="rank correlation with the FOS", xlim=(-1, 1), title="sensitivity of the FOS")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def draw_pf_sweep(out_dir: Path, ds: xr.Dataset) -> Path:
    """``pf.png``: pf with its interval against the first axis (a grid's second axis as lines)."""
    axes = [name for name in ds.coords if "sweep_path" in ds[name].attrs]
    first = axes[0]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    lines = [(None, ds)]
    if ds["pf"].ndim == 2:
        second = [d for d in ds["pf"].dims if d != first][0]
        lines = [(f"{second} = {value:g}" if np.isscalar(value) else str(value), ds.sel({second: value}))
                 for value in ds[second].values]
    elif ds["pf"].ndim > 2:
        lines = [(None, ds.isel({d: ds.sizes[d] // 2 for d in ds["pf"].dims if d != first}))]
    for label, part in lines:
        x, pf = part[first].values, part["pf"].values
        error = np.vstack([pf - part["pf_low"].values, part["pf_high"].values - pf])
        ax.errorbar(x, pf, yerr=error, marker="o", capsize=3, label=label)
    units = ds[first].attrs.get("units", "1")
    ax.set(xlabel=first if units in ("1", "") else f"{first} ({units})", ylabel="probability of failure",
           ylim=(0, 1), title=f"{ds.attrs['study_name']}: pf with its 95% interval")
    if len(lines) > 1:
        ax.legend()
    fig.tight_layout()
    path = out_dir / "pf.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
