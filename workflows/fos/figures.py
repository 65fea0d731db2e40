"""Figures of a strength-reduction study (PNG, matplotlib without a display).

Fixed margins, not constrained layout: the layout solver took a third of the figures' time,
which is serial time at the end of every study.

- ``srf_curve.png``: largest displacement against SRF (log scale), each run coloured by its
  verdict, the knee (maximum curvature of the sweep) and the FOS bracket marked;
- ``fields_srf_<F>.png`` for the last stable and the first failed SRF around the bracket:
  equivalent plastic strain and displacement magnitude on the final particle positions, with the
  water (piezometric line dashed, ponded water solid), the surface loads and the seismic coefficient.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.fos.run_store import run_file_name
from workflows.loading import surface_height_m
from workflows.study import parse_study

COLOURS = {"stable": "tab:blue", "failed": "tab:red", "diverged": "tab:gray"}


def pyplot():
    """matplotlib's pyplot on the Agg backend.  Imported on first use, not with this module:
    it costs about 0.5 s, which a study with ``figures = false`` never pays."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def srf_curve(summary: xr.Dataset, path: Path) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.12, top=0.92)
    srf = summary["srf"].values
    u = np.maximum(summary["max_displacement"].values, summary.attrs["displacement_floor_m"])  # log axis
    status = summary["status"].values.astype(str)
    ax.plot(srf, u, "-", color="0.6", lw=1)
    for name, colour in COLOURS.items():
        pick = status == name
        if pick.any():
            ax.plot(srf[pick], u[pick], "o", color=colour, label=name)
    fos = summary["fos"]
    knee = float(fos.attrs.get("knee_srf", math.nan))
    if math.isfinite(knee):
        ax.axvline(knee, color="tab:green", ls="--", lw=1, label=f"knee (maximum curvature) {knee:g}")
    if math.isfinite(float(fos)):
        low, high = fos.attrs["fos_low"], fos.attrs["fos_high"]
        ax.axvspan(low, high, color="orange", alpha=0.3, label=f"FOS {float(fos):.3f} [{low:.4g}, {high:.4g}]")
        ax.axvline(low, color="orange", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("strength reduction factor F")
    ax.set_ylabel("largest displacement (m)")
    ax.set_title(f"{summary.attrs.get('study_name', '')}: SRF against displacement")
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def final_state_figure(result_path: Path, path: Path, title, decorate=None) -> Path:
    """Equivalent plastic strain and displacement on the final particle positions of a result file,
    into ``path``; ``title(ds)`` gives the title, ``decorate(ax, study)`` draws over each panel."""
    plt = pyplot()
    import matplotlib.tri as mtri  # with pyplot, see pyplot

    with xr.open_dataset(result_path, engine="netcdf4") as ds:
        x, y = ds["particle_x"].values, ds["particle_y"].values
        triangles = ds["mesh2d_face_nodes"].values
        plastic = ds["particle_plastic_strain"].values
        u = np.hypot(ds["particle_ux"].values, ds["particle_uy"].values)
        heading = title(ds)
        study_text = ds.attrs.get("study", "")
    mesh = mtri.Triangulation(x, y, triangles)
    study = parse_study(study_text) if study_text else None
    # panels as tall as the domain's aspect asks (equal axes), within 1-3.5 in each
    aspect = (np.ptp(y) or 1.0) / (np.ptp(x) or 1.0)
    panel_in = min(max(5.6 * aspect, 1.0), 3.5)
    height_in = 2.0 * panel_in + 1.3
    fig, axes = plt.subplots(2, 1, figsize=(7.5, height_in), sharex=True)
    fig.subplots_adjust(left=0.09, right=0.97, bottom=0.55 / height_in, top=1.0 - 0.4 / height_in, hspace=0.25)
    for ax, values, label in ((axes[0], plastic, "equivalent plastic strain"), (axes[1], u, "displacement (m)")):
        shading = ax.tripcolor(mesh, values, shading="gouraud", cmap="viridis")
        fig.colorbar(shading, ax=ax, label=label)
        ax.set_aspect("equal")
        ax.set_ylabel("y (m)")
        if study is not None and decorate is not None:
            decorate(ax, study)
    axes[0].set_title(heading)
    axes[1].set_xlabel("x (m)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def run_fields(run_path: Path, path: Path) -> Path:
    """The final state of an SRF run, with its water and loads."""
    return final_state_figure(run_path, path, lambda ds: f"SRF {float(ds.attrs['srf']):g} ({ds.attrs['status']}), "
                              "final state", draw_water_and_loads)


def draw_water_and_loads(ax, study) -> None:
    """The piezometric line (dashed) and ponded water (solid) in blue, surface loads as red arrows
    and the seismic coefficient as a note, over a field plot of ``study``'s domain."""
    polygon = np.array(study.geometry.polygon_m)
    x_lo, x_hi = polygon[:, 0].min(), polygon[:, 0].max()
    x = np.linspace(x_lo, x_hi, 400)
    ground = surface_height_m(polygon, x)
    water = study.water
    lines = [] if water is None or water.phreatic_line is None else [water.phreatic_line]
    lines += [m.phreatic_line_m for m in study.materials if m.phreatic_line_m is not None]
    for line in map(np.array, lines):
        ax.plot(x, np.minimum(np.interp(x, line[:, 0], line[:, 1]), ground), "--", color="tab:blue", lw=1.2)
    if water is not None and water.pond_level_m is not None:
        ax.plot(x, np.where(ground < water.pond_level_m, water.pond_level_m, np.nan), "-", color="tab:blue", lw=1.5)
    reach = 0.06 * (polygon[:, 1].max() - polygon[:, 1].min() or 1.0)
    arrows = [(xs, load.pressure_pa) for load in study.loads.strip
              for xs in np.linspace(load.x_start_m, load.x_end_m, 5)]
    arrows += [(load.x_m, load.force_n_m) for load in study.loads.line]
    for x_load, _ in arrows:
        y_top = float(surface_height_m(polygon, np.array([x_load]))[0])
        ax.annotate("", xy=(x_load, y_top), xytext=(x_load, y_top + reach),
                    arrowprops=dict(arrowstyle="->", color="tab:red", lw=1.2), annotation_clip=False)
    seismic = study.loads.seismic
    if seismic is not None:
        ax.text(0.01, 0.03, f"kh = {seismic.horizontal_coefficient:g}, kv = {seismic.vertical_coefficient:g}",
                transform=ax.transAxes, fontsize=8, color="tab:red")


def draw_figures(out_dir: Path, summary: xr.Dataset) -> list[Path]:
    """The SRF curve and the fields at the last stable and first failed SRF (module doc)."""
    paths = [srf_curve(summary, out_dir / "srf_curve.png")]
    srf = summary["srf"].values
    status = summary["status"].values.astype(str)
    failed = srf[status == "failed"]
    picks = []
    if failed.size:
        first_failed = failed.min()
        stable_below = srf[(status == "stable") & (srf < first_failed)]
        if stable_below.size:
            picks.append(stable_below.max())
        picks.append(first_failed)
    elif (status == "stable").any():
        picks.append(srf[status == "stable"].max())
    for value in picks:
        run_path = out_dir / run_file_name(float(value))
        if run_path.is_file():
            paths.append(run_fields(run_path, out_dir / f"fields_srf_{value:.4f}.png"))
    return paths
