"""Figures of a probabilistic study, drawn from ``probabilistic.nc`` or a sweep's ``study.nc``
(PNG, matplotlib without a display).

- ``pf_convergence.png``: pf of the first n realisations against n, with its exact 95% interval
  (Clopper-Pearson, ``reliability.failure_probability``) as a band;
- ``fos_distribution.png`` (fos mode): the histogram of the realisations' FOS and their empirical
  CDF, the factor the study judges at and pf marked;
- ``sensitivity.png`` (fos mode, random variables): each variable's rank correlation with the FOS;
- ``failed_<realisation>.png``: for the first :data:`FAILED_FIGURES` failed realisations of a study
  with a ``[random_field]``, each field at the particles beside the run's final plastic strain
  (where the weak zones were, and the mechanism through them);
- ``pf.png`` of a sweep: pf with its interval against the first axis, one line per value of a
  second.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot, save_figure
from workflows.particles import cloud
from workflows.probabilistic.kinds import COMPUTATIONS
from workflows.probabilistic.reliability import failure_probability
from workflows.random_field.table import SEEPAGE_PROPERTY
from workflows.scene import field_values
from workflows.study import parse_study

FAILED_FIGURES = 3

FIGURE_NAMES = ("pf_convergence.png", "failed_*.png", "fos_distribution.png", "sensitivity.png", "slip_envelope.png")
"""The figures :func:`draw_probabilistic_figures` may draw: those of an earlier invocation it did not
draw again are removed (``output.figures.remove_stale_figures``)."""


def draw_probabilistic_figures(out_dir: Path, ds: xr.Dataset, study=None, slip_lines: list | None = None) -> list[Path]:
    """Every figure of one probabilistic study that its dataset supports (module doc)."""
    paths = [pf_convergence(out_dir / "pf_convergence.png", ds)]
    if study is not None and study.random_field is not None:
        failed = [str(folder) for folder, verdict in zip(ds["case_folder"].values, ds["verdict"].values)
                  if verdict == "failed"][:FAILED_FIGURES]
        paths += [failed_realisation(out_dir / "cases" / folder, out_dir / f"failed_{folder}.png")
                  for folder in failed]
        paths = [path for path in paths if path is not None]
    if "slip_envelope_x" in ds and study is not None:
        paths.append(slip_envelope(out_dir / "slip_envelope.png", ds, study, slip_lines))
    fos = ds["fos"].values
    if COMPUTATIONS[ds.attrs["compute"]].searches and np.isfinite(fos).sum() >= 3:
        paths.append(fos_distribution(out_dir / "fos_distribution.png", ds))
        if "fos_rank_correlation" in ds:
            paths.append(sensitivity(out_dir / "sensitivity.png", ds))
    return paths


def slip_envelope(path: Path, ds: xr.Dataset, study, lines: list | None = None) -> Path:
    """The section, the failed realisations' slip lines (``lines``, when given) and their deepest
    envelope."""
    plt = pyplot()
    polygon = np.array([*study.geometry.polygon_m, study.geometry.polygon_m[0]])
    width = float(np.ptp(polygon[:, 0]))
    fig, ax = plt.subplots(figsize=(8.0, max(2.5, 8.0 * float(np.ptp(polygon[:, 1])) / width + 1.0)))
    ax.plot(polygon[:, 0], polygon[:, 1], color="0.3", lw=1.0)
    x = ds["slip_envelope_x"].values
    for i, (line_x, line_y) in enumerate(lines or []):
        ax.plot(line_x, line_y, color="tab:red", lw=0.6, alpha=0.35,
                label="a failed realisation's slip line" if i == 0 else None)
    ax.plot(x, ds["slip_envelope_lower"].values, color="tab:red", lw=1.8,
            label=f"deepest of the {ds['slip_envelope_x'].attrs['n_lines']} slip lines")
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    ax.set_title(f"{ds.attrs['study_name']}: envelope of the failed realisations' slip lines, pf {ds.attrs['pf']:.3g}",
                 fontsize=9)
    ax.legend(loc="lower left", fontsize=8)
    save_figure(fig, path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def pf_convergence(path: Path, ds: xr.Dataset) -> Path:
    verdict = ds["verdict"].values
    decided = np.cumsum(verdict != "undecided")
    failed = np.cumsum(verdict == "failed")
    n, pf, low, high = [], [], [], []
    for k, f in zip(decided, failed):
        if k:
            estimate = failure_probability(int(f), int(k))
            n.append(k)
            pf.append(estimate[0])
            low.append(estimate[1])
            high.append(estimate[2])
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.fill_between(n, low, high, color="tab:blue", alpha=0.25, label="95% interval")
    ax.plot(n, pf, color="tab:blue", label="pf")
    ax.set(xlabel="realisations", ylabel="probability of failure", ylim=(0, 1),
           title=f"{ds.attrs['study_name']}: pf = {ds.attrs['pf']:.3g} [{ds.attrs['pf_low']:.3g}, "
                 f"{ds.attrs['pf_high']:.3g}]")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
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
    save_figure(fig, path, dpi=120)
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
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def draw_pf_sweep(out_dir: Path, ds: xr.Dataset) -> Path:
    """``pf.png``: pf with its interval against the first axis (a grid's second axis as lines)."""
    axes = [name for name in ds.coords if "sweep_path" in ds[name].attrs]
    first = axes[0]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    lines: list[tuple[str | None, xr.Dataset]] = [(None, ds)]
    if ds["pf"].ndim == 2:
        second = str([d for d in ds["pf"].dims if d != first][0])
        lines = [(f"{second} = {format(value, 'g')}" if np.isscalar(value) else str(value), ds.sel({second: value}))
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
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def failed_realisation(folder: Path, path: Path) -> Path | None:
    """The realisation's fields at its particles (from its ``case.toml``) and the final plastic
    strain of its failed run with the lowest SRF; None when no failed run file with the particle state
    is there (``keep_fields``)."""
    import matplotlib.tri as mtri  # matplotlib: only when drawing


    runs = []
    for run_file in sorted(folder.glob("srf_*.nc")):
        with xr.open_dataset(run_file, engine="netcdf4") as run:
            if run.attrs.get("status") == "failed" and run.attrs.get("particle_fields", 1):
                runs.append((float(run.attrs["srf"]), run_file))
    if not runs:
        return None
    srf, run_file = min(runs)
    study = parse_study((folder / "case.toml").read_text())
    node_xy_m, _ = cloud(study)
    values = field_values(study)  # (the permeability too, which the scene leaves to the flow)
    names = [entry.property for entry in study.random_field.properties]
    with xr.open_dataset(run_file, engine="netcdf4") as run:
        x, y = run["particle_x"].values, run["particle_y"].values
        triangles = run["mesh2d_face_nodes"].values
        plastic = run["particle_plastic_strain"].values
    plt = pyplot()
    fig, axes = plt.subplots(len(names) + 1, 1, figsize=(7.5, 2.6 * (len(names) + 1)), sharex=True)
    x0, y0 = node_xy_m[:, 0], node_xy_m[:, 1]
    for ax, name in zip(axes, names):
        norm = "log" if name == SEEPAGE_PROPERTY else None  # a permeability spans decades
        dots = ax.scatter(x0, y0, c=values[name], s=4, cmap="viridis", norm=norm)
        fig.colorbar(dots, ax=ax, label=name)
        ax.set(aspect="equal", ylabel="y (m)")
    shading = axes[-1].tripcolor(mtri.Triangulation(x, y, triangles), plastic, shading="gouraud", cmap="magma")
    fig.colorbar(shading, ax=axes[-1], label="equivalent plastic strain")
    axes[-1].set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    axes[0].set_title(f"{folder.name}: failed at SRF {srf:g}")
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
