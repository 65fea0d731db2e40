"""Design charts of a sweep, drawn from ``study.nc`` (PNG, matplotlib without a display).

- ``fos_<axis>.png`` per axis: the FOS against the axis, one line per value of a second axis
  (a grid's next axis; further axes at their middle value, named in the title).  A case with
  no FOS in the SRF range is drawn as an open triangle at the bound it has: up at the highest
  stable SRF (the FOS is above), down at the lowest failed SRF (below).  FOS = 1 is dashed.
- ``fos_map.png`` for a grid of two or more numeric axes: filled contours of the FOS over the
  first two axes, the FOS = 1 line drawn and labelled, each case marked with its value.
- ``runout_<axis>.png`` per axis of a runout study's sweep: runout and retrogression against the
  axis, one line per runout stage (other axes at their middle value, named in the title).

:func:`draw_sweep_figures` is what a sweep calls; the notebook ``studies/notebooks/sweep_results.ipynb``
calls :func:`fos_lines` and :func:`fos_map` on a ``study.nc`` it opens.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot, save_figure
from workflows.sweep.results import ABOVE, BELOW, FOUND


def _axes(ds: xr.Dataset) -> list[str]:
    """The swept coordinates, in the order of the axes."""
    return [str(name) for name in ds.coords if "sweep_path" in ds[name].attrs]


def _label(ds: xr.Dataset, name: str) -> str:
    units = ds[name].attrs.get("units", "1")
    return name if units in ("1", "") else f"{name} ({units})"


def _is_numeric(values: np.ndarray) -> bool:
    return values.dtype.kind in "iuf"


def _positions(values: np.ndarray) -> tuple[np.ndarray, list[str] | None]:
    """x positions of axis values, and tick labels for values that are not numbers."""
    if _is_numeric(values):
        return values.astype(float), None
    return np.arange(values.size, dtype=float), [str(v) for v in values]


def _curve(ax, x, fos, low, high, status, colour, label):
    """One line: found cases joined, bounds as open triangles."""
    found = status == FOUND
    ax.plot(x[found], fos[found], "o-", color=colour, label=label, ms=5)
    if found.any():
        ax.vlines(x[found], low[found], high[found], color=colour, lw=1)
    above, below = status == ABOVE, status == BELOW
    ax.plot(x[above], low[above], "^", color=colour, mfc="none", ms=7)
    ax.plot(x[below], high[below], "v", color=colour, mfc="none", ms=7)


def _slice(ds: xr.Dataset, keep: list[str]) -> tuple[xr.Dataset, str]:
    """``ds`` with every axis not in ``keep`` at its middle value, and a note of those values."""
    fixed = {}
    for name in _axes(ds):
        if name not in keep and name in ds.dims:
            fixed[name] = ds.sizes[name] // 2
    picked = ds.isel(fixed)
    note = ", ".join(f"{name} = {picked[name].values.item():g}" if _is_numeric(picked[name].values)
                     else f"{name} = {picked[name].values.item()}" for name in fixed)
    return picked, note


def fos_lines(ds: xr.Dataset, axis: str, ax=None):
    """FOS against ``axis`` (module doc); returns the matplotlib Axes."""
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.4))
    combination = ds.attrs.get("sweep_combination", "grid")
    title = f"{ds.attrs.get('study_name', '')}: FOS against {axis}"
    if combination == "zip":
        order = np.argsort(ds[axis].values) if _is_numeric(ds[axis].values) else np.arange(ds.sizes["case"])
        picked = ds.isel(case=order)
        x, ticks = _positions(picked[axis].values)
        _curve(ax, x, picked["fos"].values, picked["fos_low"].values, picked["fos_high"].values,
               picked["status"].values.astype(str), "tab:blue", None)
    else:
        others = [name for name in _axes(ds) if name != axis]
        series = others[0] if others else None
        picked, note = _slice(ds, [axis] + ([series] if series else []))
        x, ticks = _positions(picked[axis].values)
        colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, picked.sizes[series] if series else 1))
        for j, colour in enumerate(colours):
            line = picked.isel({series: j}) if series else picked
            value = line[series].values.item() if series else None
            label = None if series is None else f"{series} = {value:g}" if _is_numeric(picked[series].values) \
                else f"{series} = {value}"
            _curve(ax, x, line["fos"].values, line["fos_low"].values, line["fos_high"].values,
                   line["status"].values.astype(str), colour, label)
        if note:
            title += f" ({note})"
    if ticks is not None:
        ax.set_xticks(x, ticks)
    ax.axhline(1.0, color="k", ls="--", lw=1)
    ax.set_xlabel(_label(ds, axis))
    ax.set_ylabel("factor of safety")
    ax.set_title(title, fontsize=10)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return ax


def can_map(ds: xr.Dataset) -> bool:
    """True for a grid with at least two numeric axes of at least two values each."""
    axes = _axes(ds)
    return (ds.attrs.get("sweep_combination") == "grid" and len(axes) >= 2
            and all(_is_numeric(ds[a].values) and ds.sizes[a] >= 2 for a in axes[:2]))


def fos_map(ds: xr.Dataset, ax=None):
    """Filled contours of the FOS over the first two axes, FOS = 1 drawn (module doc); the Axes."""
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 5.0))
    x_name, y_name = _axes(ds)[:2]
    picked, note = _slice(ds, [x_name, y_name])
    fos = picked["fos"].transpose(y_name, x_name).values.astype(float)
    x, y = picked[x_name].values.astype(float), picked[y_name].values.astype(float)
    finite = np.isfinite(fos)
    if finite.sum() >= 3 and np.nanmax(fos) > np.nanmin(fos):
        from matplotlib.ticker import MaxNLocator  # matplotlib: only when drawing

        levels = MaxNLocator(nbins=12).tick_values(np.nanmin(fos), np.nanmax(fos))
        filled = ax.contourf(x, y, np.ma.masked_invalid(fos), levels=levels, cmap="RdYlGn")
        ax.figure.colorbar(filled, ax=ax, label="factor of safety")
        if np.nanmin(fos) < 1.0 < np.nanmax(fos):
            line = ax.contour(x, y, np.ma.masked_invalid(fos), levels=[1.0], colors="k", linewidths=2)
            ax.clabel(line, fmt={1.0: "FOS = 1"}, fontsize=8)
    status = picked["status"].transpose(y_name, x_name).values.astype(str)
    gx, gy = np.meshgrid(x, y)
    low = picked["fos_low"].transpose(y_name, x_name).values
    high = picked["fos_high"].transpose(y_name, x_name).values
    for i, j in np.ndindex(fos.shape):
        text = {FOUND: f"{fos[i, j]:.2f}", ABOVE: f">{low[i, j]:g}", BELOW: f"<{high[i, j]:g}"}.get(str(status[i, j]), "-")
        ax.plot(gx[i, j], gy[i, j], "k.", ms=4, clip_on=False)
        ax.annotate(text, (gx[i, j], gy[i, j]), textcoords="offset points", xytext=(0, 5), ha="center", fontsize=7,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7})
    pad_x, pad_y = 0.06 * (x.max() - x.min()), 0.06 * (y.max() - y.min())
    ax.set_xlim(x.min() - pad_x, x.max() + pad_x)
    ax.set_ylim(y.min() - pad_y, y.max() + pad_y)
    ax.set_xlabel(_label(ds, x_name))
    ax.set_ylabel(_label(ds, y_name))
    title = f"{ds.attrs.get('study_name', '')}: factor of safety"
    ax.set_title(title + (f" ({note})" if note else ""), fontsize=10)
    return ax


def _per_axis(out_dir: Path, ds: xr.Dataset, draw, prefix: str) -> list[Path]:
    """``<prefix>_<axis>.png`` per axis, each drawn by ``draw(ds, axis, ax)``; their paths."""
    plt = pyplot()
    paths = []
    for axis in _axes(ds):
        fig, ax = plt.subplots(figsize=(6.4, 4.4))
        fig.subplots_adjust(left=0.11, right=0.97, bottom=0.12, top=0.91)
        draw(ds, axis, ax)
        paths.append(out_dir / f"{prefix}_{axis}.png")
        save_figure(fig, paths[-1], dpi=110)
        plt.close(fig)
    return paths


def draw_sweep_figures(out_dir: Path, ds: xr.Dataset) -> list[Path]:
    """``fos_<axis>.png`` per axis and (:func:`can_map`) ``fos_map.png`` in ``out_dir``; their paths."""
    plt = pyplot()
    paths = _per_axis(out_dir, ds, fos_lines, "fos")
    if can_map(ds):
        fig, ax = plt.subplots(figsize=(6.4, 5.0))
        fig.subplots_adjust(left=0.13, right=0.97, bottom=0.11, top=0.92)
        fos_map(ds, ax)
        paths.append(out_dir / "fos_map.png")
        save_figure(fig, paths[-1], dpi=110)
        plt.close(fig)
    return paths


def runout_lines(ds: xr.Dataset, axis: str, ax=None):
    """Runout (solid) and retrogression (dashed) against ``axis``, a colour per runout stage; the Axes."""
    plt = pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 4.4))
    title = f"{ds.attrs.get('study_name', '')}: runout and retrogression"
    if ds.attrs.get("sweep_combination") == "zip":
        order = np.argsort(ds[axis].values) if _is_numeric(ds[axis].values) else np.arange(ds.sizes["case"])
        picked, note = ds.isel(case=order), ""
    else:
        picked, note = _slice(ds, [axis])
    x, ticks = _positions(picked[axis].values)
    stages = [str(s) for s in picked["runout_stage"].values]
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(stages)))
    for s, (stage, colour) in enumerate(zip(stages, colours)):
        line = picked.isel(runout_stage=s)
        ax.plot(x, line["runout_m"].values, "o-", color=colour, label=f"{stage}: runout", ms=5)
        ax.plot(x, line["retrogression_m"].values, "s--", color=colour, label=f"{stage}: retrogression", ms=5,
                mfc="none")
    if ticks is not None:
        ax.set_xticks(x, ticks)
    ax.set_xlabel(_label(ds, axis))
    ax.set_ylabel("distance (m)")
    ax.set_title(title + (f" ({note})" if note else ""), fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return ax


def draw_runout_sweep(out_dir: Path, ds: xr.Dataset) -> list[Path]:
    """``runout_<axis>.png`` per axis in ``out_dir``; their paths."""
    return _per_axis(out_dir, ds, runout_lines, "runout")
