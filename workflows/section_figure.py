"""The section drawn as a study will run it: particles coloured by material, the particles a support
holds (x, y or both), walls, refined zones, water (piezometric lines or the steady flow's water
table dashed, ponded water solid), surface loads (arrows), monitors, and the critical circle of a
limit-equilibrium search.  ``spfem-fos check`` draws it into ``OUT/section.png``
(``workflows.check``), ``report.html`` at its head (``workflows.html_report``).
"""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO, TypeVar

import numpy as np

from workflows.fos.figures import draw_water_and_loads
from workflows.output.figures import pyplot, save_figure
from workflows.scene import supports
from workflows.study import Study

PathOrFile = TypeVar("PathOrFile", Path, BinaryIO)  # a PNG file, or a buffer it is drawn into


def draw_section(study: Study, scene, path: PathOrFile, critical=None, flow=None) -> PathOrFile:
    """The section of the module doc into ``path``, with the ``critical`` circle of a limit-equilibrium
    search (``fos.critical_circle``) dashed where it lies in the ground, and the water table of the
    study's steady ``flow`` (``workflows.seepage.flow``) with ``[seepage]``."""
    plt = pyplot()
    xy = scene.node_xy_m
    polygon = np.array(study.geometry.polygon_m)
    span = np.ptp(polygon, axis=0)
    width_in = 8.0
    axes_in = min(max(1.1 * 0.9 * width_in * span[1] / max(span[0], 1e-30), 1.5), 7.0)  # equal axes, 5% margins
    height_in = axes_in + 1.3
    fig, ax = plt.subplots(figsize=(width_in, height_in))
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.9 / height_in, top=1.0 - 0.4 / height_in)
    marker = max(0.3, min(8.0, 2.0e4 / max(scene.n_particles, 1)))
    colours = plt.get_cmap("tab10")
    for i, material in enumerate(study.materials):
        mine = scene.node_material == i
        ax.scatter(xy[mine, 0], xy[mine, 1], s=marker, color=colours(i % 10), lw=0, label=material.name)
    ring = np.vstack([polygon, polygon[:1]])
    ax.plot(ring[:, 0], ring[:, 1], "-", color="0.3", lw=0.8)
    held = supports(study, scene).fixed
    for pick, symbol, label in ((held[:, 0] & held[:, 1], "s", "held in x and y"),
                                (held[:, 0] & ~held[:, 1], ">", "held in x"),
                                (~held[:, 0] & held[:, 1], "^", "held in y")):
        if pick.any():
            ax.scatter(xy[pick, 0], xy[pick, 1], s=4 * marker + 4, marker=symbol, facecolor="none",
                       edgecolor="black", lw=0.5, label=label)
    for wall in study.walls:
        (x1, y1), (x2, y2) = wall.start_m, wall.end_m
        ax.plot([x1, x2], [y1, y2], "-", color="saddlebrown", lw=2.5)
        ax.annotate(wall.name, ((x1 + x2) / 2, (y1 + y2) / 2), fontsize=8, color="saddlebrown")
    for zone in study.geometry.refined:
        zone_ring = np.vstack([zone.region_m, zone.region_m[:1]])
        ax.plot(zone_ring[:, 0], zone_ring[:, 1], ":", color="tab:purple", lw=1.2)
    draw_water_and_loads(ax, study, flow)
    if critical is not None:
        low, high = sorted((critical.entry_x_m, critical.exit_x_m))
        x = np.linspace(low, high, 200)
        y = critical.centre_m[1] - np.sqrt(np.maximum(critical.radius_m**2 - (x - critical.centre_m[0]) ** 2, 0.0))
        ax.plot(x, y, "--", color="tab:red", lw=1.0, label=f"critical circle (Bishop, F {critical.fos:.3g})")
    for monitor in study.monitors:
        ax.plot(monitor.x_m, monitor.y_m, "x", color="tab:red", ms=7, mew=1.5)
        ax.annotate(monitor.name, (monitor.x_m, monitor.y_m), xytext=(4, 4), textcoords="offset points",
                    fontsize=8, color="tab:red")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{study.name}: {scene.n_particles} particles at h = {study.geometry.spacing_m:g} m")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=6, fontsize=7, frameon=False,
              markerscale=max(1.0, 6.0 / marker))
    save_figure(fig, path, dpi=120, bbox_inches="tight", pad_inches=0.15)  # equal axes leave no gap
    plt.close(fig)
    return path
