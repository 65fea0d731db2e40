"""``seepage.png``: the steady flow over the section, from ``seepage.nc``: the total head (colour and
contours), the flow (arrows of the Darcy velocity, their length its logarithm), the phreatic
surface (blue) and the exit point (a dot)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.figures import pyplot, save_figure

ARROWS = 400
"""About this many flow arrows, on the triangles a regular sampling picks."""
FLOWING = 1e-2
"""Arrows only where the Darcy speed is at least this fraction of the largest."""


def draw_seepage(ds: xr.Dataset, path: Path) -> Path:
    """The figure of the module doc into ``path``."""
    import matplotlib.tri as mtri  # matplotlib: only when drawing

    x, y = ds["particle_x"].values, ds["particle_y"].values
    triangles = ds["mesh2d_face_nodes"].values
    mesh = mtri.Triangulation(x, y, triangles)
    plt = pyplot()
    aspect = (np.ptp(y) or 1.0) / (np.ptp(x) or 1.0)
    height_in = min(max(7.0 * aspect, 1.5), 5.0) + 1.2
    fig, ax = plt.subplots(figsize=(8.5, height_in))
    fig.subplots_adjust(left=0.08, right=0.97, bottom=0.7 / height_in, top=1.0 - 0.45 / height_in)
    head = ds["total_head"].values
    shading = ax.tricontourf(mesh, head, levels=20, cmap="viridis_r")
    if np.ptp(head) > 0.0:
        ax.tricontour(mesh, head, levels=10, colors="k", linewidths=0.4, alpha=0.5)
    fig.colorbar(shading, ax=ax, label="total head (m)")
    vx, vy = ds["darcy_vx"].values, ds["darcy_vy"].values
    pick = np.arange(0, len(vx), max(1, len(vx) // ARROWS))
    speed = np.hypot(vx[pick], vy[pick])
    flowing = speed >= FLOWING * speed.max()  # not the trickle above the water table
    pick, speed = pick[flowing], speed[flowing]
    if speed.size and speed.max() > 0.0:
        # arrows point along the flow; their length grows with log speed over two decades
        length = np.clip(np.log10(speed / speed.max()) / 2.0 + 1.0, 0.1, 1.0)
        cx, cy = x[triangles[pick]].mean(axis=1), y[triangles[pick]].mean(axis=1)
        ux, uy = vx[pick] / np.maximum(speed, 1e-300), vy[pick] / np.maximum(speed, 1e-300)
        ax.quiver(cx, cy, ux * length, uy * length, color="white", width=0.002, alpha=0.8)
    for xs, ys in zip(ds["phreatic_x"].values, ds["phreatic_y"].values):
        ax.plot(xs, ys, color="tab:blue", lw=1.5)
    if np.isfinite(ds.attrs["exit_x_m"]):
        ax.plot(ds.attrs["exit_x_m"], ds.attrs["exit_y_m"], "o", color="tab:blue", ms=5)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title=f"{ds.attrs['study_name']}: steady seepage, {ds.attrs['outflow_m2_s']:.3g} m2/s per metre "
                 f"({ds.attrs['iterations']} iterations)")
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
