"""Figures of a strength-reduction study (PNG, matplotlib without a display, ``workflows.output.figures``).

- ``srf_curve.png``: largest displacement against SRF (log scale), each run coloured by its
  verdict, the knee (maximum curvature of the sweep) and the FOS bracket marked;
- ``fields_srf_<F>.png`` for the last stable and the first failed SRF around the bracket:
  equivalent plastic strain and displacement magnitude on the final particle positions, with the
  water (piezometric line dashed, ponded water solid, ``workflows.water.figures.draw_water``), the surface
  loads (their ``arrows_m``) and the seismic coefficient;
- ``particle_spacing.png`` of a graded cloud (``[[geometry.refined]]``): each particle at its initial
  position coloured by its spacing.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.geometry import surface_height_m
from workflows.fos.run_store import run_file_name
from workflows.output.figures import final_state_figure, pyplot, save_figure
from workflows.study import parse_study
from workflows.water.figures import draw_water

COLOURS = {"stable": "tab:blue", "failed": "tab:red", "diverged": "tab:gray"}


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
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def run_fields(run_path: Path, path: Path, flow=None) -> Path:
    """The final state of an SRF run, with its water (``flow``: the steady flow of its study, if it has
    one and the caller has it) and loads."""

    def decorate(ax, attrs) -> None:
        if attrs.get("study"):
            draw_water_and_loads(ax, parse_study(attrs["study"]), flow)

    return final_state_figure(run_path, path, lambda ds: f"SRF {float(ds.attrs['srf']):g} ({ds.attrs['status']}), "
                              "final state", decorate)


def draw_water_and_loads(ax, study, flow=None) -> None:
    """The water (``workflows.water.figures.draw_water``: the study's steady ``flow`` with ``[seepage]``,
    solved there when not given), the surface loads as red arrows and the seismic coefficient as a note,
    over a field plot of ``study``'s domain."""
    polygon = np.array(study.geometry.polygon_m)
    x_lo, x_hi = polygon[:, 0].min(), polygon[:, 0].max()
    x = np.linspace(x_lo, x_hi, 400)
    draw_water(ax, study, x, surface_height_m(polygon, x), flow)
    reach = 0.06 * (polygon[:, 1].max() - polygon[:, 1].min() or 1.0)
    for _, load in study.loads.surface_loads():
        for x_load in load.arrows_m():
            y_top = float(surface_height_m(polygon, np.array([x_load]))[0])
            ax.annotate("", xy=(x_load, y_top), xytext=(x_load, y_top + reach),
                        arrowprops=dict(arrowstyle="->", color="tab:red", lw=1.2), annotation_clip=False)
    seismic = study.loads.seismic
    if seismic is not None:
        ax.text(0.01, 0.03, seismic.note(), transform=ax.transAxes, fontsize=8, color="tab:red")


FIGURE_NAMES = ("srf_curve.png", "fields_srf_*.png", "particle_spacing.png", "slip_surface.png")
"""The figures :func:`draw_figures` may draw: those of an earlier invocation it did not draw again
are removed (``output.figures.remove_stale_figures``)."""


def draw_figures(out_dir: Path, summary: xr.Dataset, flow=None) -> list[Path]:
    """The SRF curve and the fields at the last stable and first failed SRF (module doc); ``flow``: the
    case's steady flow, when it has one."""
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
            paths.append(run_fields(run_path, out_dir / f"fields_srf_{value:.4f}.png", flow))
    if summary.sizes.get("slip_point", 0) and (out_dir / run_file_name(float(summary["slip_srf"]))).is_file():
        paths.append(slip_figure(summary, out_dir, out_dir / "slip_surface.png"))
    if picks and (run_path := out_dir / run_file_name(float(picks[0]))).is_file():
        with xr.open_dataset(run_path) as ds:
            if "particle_spacing" in ds:
                paths.append(spacing_map(ds, out_dir / "particle_spacing.png"))
    return paths


def slip_figure(summary: xr.Dataset, out_dir: Path, path: Path) -> Path:
    """The slip line on the section: the particles at their initial positions coloured by the
    mechanism's displacement (the failed run's beyond the stable run's), the line, its ends, and
    the two factors of safety."""
    plt = pyplot()
    srf, stable_srf = float(summary["slip_srf"]), float(summary["slip_srf"].attrs.get("stable_srf", np.nan))
    with xr.open_dataset(out_dir / run_file_name(srf)) as failed:
        x0, y0 = failed["particle_x0"].values, failed["particle_y0"].values
        ux, uy = failed["particle_ux"].values, failed["particle_uy"].values
    if not np.isnan(stable_srf) and (out_dir / run_file_name(stable_srf)).is_file():
        with xr.open_dataset(out_dir / run_file_name(stable_srf)) as stable:
            ux, uy = ux - stable["particle_ux"].values, uy - stable["particle_uy"].values
    moved = np.maximum(np.hypot(ux, uy), 1e-9)
    width = max(float(np.ptp(x0)), 1e-9)
    fig, ax = plt.subplots(figsize=(8.0, max(2.5, 8.0 * float(np.ptp(y0)) / width + 1.0)))
    log_moved = np.log10(moved)
    points = ax.scatter(x0, y0, c=log_moved, s=2.0, cmap="viridis", vmin=log_moved.max() - 3.0, vmax=log_moved.max())
    fig.colorbar(points, ax=ax, shrink=0.8, label="log10 displacement (m)")
    ax.plot(summary["slip_x"].values, summary["slip_y"].values, color="tab:red", lw=2.0, label="slip line")
    ax.plot([float(summary["slip_entry_x"]), float(summary["slip_exit_x"])],
            [float(summary["slip_entry_y"]), float(summary["slip_exit_y"])], "o", color="tab:red", ms=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fos, le = float(summary["fos"]), float(summary["le_fos"])
    le_text = f"Spencer on this line {le:.3f}" if not np.isnan(le) else "no limit-equilibrium FOS"
    mechanism = f"SRF {srf:g}" + ("" if np.isnan(stable_srf) else f" beyond SRF {stable_srf:g}")
    ax.set_title(f"slip surface of the run at {mechanism}: {float(summary['slip_depth']):.2f} m deep, "
                 f"{float(summary['slip_area']):.1f} m2\nFOS {fos:.3f} by strength reduction, {le_text}", fontsize=9)
    ax.legend(loc="lower left", fontsize=8)
    save_figure(fig, path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def spacing_map(ds: xr.Dataset, path: Path) -> Path:
    """Every particle at its initial position, coloured by its spacing (a graded cloud)."""
    plt = pyplot()
    x0, y0, h = ds["particle_x0"].values, ds["particle_y0"].values, ds["particle_spacing"].values
    width = max(float(np.ptp(x0)), 1e-9)
    fig, ax = plt.subplots(figsize=(8.0, max(2.5, 8.0 * float(np.ptp(y0)) / width + 0.8)))
    points = ax.scatter(x0, y0, c=h, s=2.0, cmap="viridis_r")
    fig.colorbar(points, ax=ax, label="particle spacing h (m)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"particle spacing: {h.size} particles, h = {h.min():.3g} to {h.max():.3g} m", fontsize=10)
    save_figure(fig, path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path
