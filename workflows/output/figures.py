"""What every figure of a result shares: matplotlib without a display, and the final state of a
stage drawn on its particles.

Fixed margins, not constrained layout: the layout solver took a third of the figures' time,
which is serial time at the end of every study.  matplotlib and xarray are imported on first use,
not with this module: a study with ``figures = false`` never pays for them.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np


def pyplot():
    """matplotlib's pyplot on the Agg backend (about 0.5 s to import)."""
    import matplotlib  # matplotlib: only when drawing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib: only when drawing

    return plt


def import_pyplot_in_background() -> None:
    """Import pyplot on a daemon thread now, so that the figures a study draws at its end do not
    wait for the import (0.65 s of the reference study's 1.7 s of figures): the client mostly
    waits for its workers meanwhile."""
    threading.Thread(target=pyplot, name="pyplot-import", daemon=True).start()


FIGURE_SOFTWARE = "spfem-fos"
"""The PNG ``Software`` text of every figure :func:`save_figure` writes: what marks a picture as ours."""


def save_figure(fig, path, **options):
    """Save ``fig`` to ``path`` (PNG), marked as ours (:data:`FIGURE_SOFTWARE`), so that a later
    study may replace or remove it and never touches a picture of the user's; ``path`` as a Path,
    or the binary file object it was (a picture kept in memory)."""
    fig.savefig(path, metadata={"Software": FIGURE_SOFTWARE}, format="png", **options)
    return Path(path) if isinstance(path, (str, Path)) else path


def drawn_by_us(path: Path) -> bool:
    """Whether the PNG ``path`` carries our mark (:func:`save_figure`)."""
    from PIL import Image  # pillow (matplotlib's own PNG library): reads the text chunks

    try:
        with Image.open(path) as image:
            return image.info.get("Software") == FIGURE_SOFTWARE
    except (OSError, ValueError):
        return False


def remove_stale_figures(out_dir: Path, patterns: tuple[str, ...], keep: set[str]) -> list[str]:
    """Remove the figures of an earlier invocation in ``out_dir`` that this one did not draw: names
    matching ``patterns``, not in ``keep``, and marked as ours (a user's picture stays); their names."""
    removed = []
    for pattern in patterns:
        for path in sorted(Path(out_dir).glob(pattern)):
            if path.name not in keep and drawn_by_us(path):
                path.unlink(missing_ok=True)
                removed.append(path.name)
    return removed


def final_state_figure(result_path: Path, path: Path, title, decorate=None) -> Path:
    """Equivalent plastic strain and displacement on the final particle positions of a result file,
    into ``path``; ``title(ds)`` gives the title from the dataset, ``decorate(ax, ds)`` draws over
    each panel."""
    import matplotlib.tri as mtri  # matplotlib and xarray: only when drawing (light importers use this module)
    import xarray as xr

    plt = pyplot()
    with xr.open_dataset(result_path, engine="netcdf4") as ds:
        x, y = ds["particle_x"].values, ds["particle_y"].values
        triangles = ds["mesh2d_face_nodes"].values
        plastic = ds["particle_plastic_strain"].values
        u = np.hypot(ds["particle_ux"].values, ds["particle_uy"].values)
        heading = title(ds)
        attrs = dict(ds.attrs)
    mesh = mtri.Triangulation(x, y, triangles)
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
        if decorate is not None:
            decorate(ax, attrs)
    axes[0].set_title(heading)
    axes[1].set_xlabel("x (m)")
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
