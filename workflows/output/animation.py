"""An animation of a stage (GIF, matplotlib with pillow): the particles at their positions, coloured
by equivalent plastic strain or displacement, one frame every ``[output] animation_interval_s``.

Frames are kept in memory during the stage (positions and one value per particle) and drawn into
``OUT/<stage>.gif`` when it ends, through a temporary name and a rename.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from workflows.output.figures import pyplot

FRAMES_PER_SECOND = 10


class AnimationRecorder:
    """A ``Simulation.run`` snapshot callback that keeps a frame per ``spfem_core.snapshot.Snapshot``;
    :meth:`write` draws them."""

    def __init__(self, path: str | Path, colour_by: str):
        self.path = Path(path)
        self.colour_by = colour_by
        self.frames: list[tuple[float, np.ndarray, np.ndarray]] = []

    def __call__(self, snapshot) -> None:
        if self.colour_by == "displacement":
            values = np.hypot(snapshot.displacement_m[:, 0], snapshot.displacement_m[:, 1])
        else:
            values = snapshot.plastic_strain
        self.frames.append((float(snapshot.time_s), snapshot.xy_m, values))

    def write(self) -> Path | None:
        """Draw the frames into the GIF; None when there are none."""
        if not self.frames:
            return None
        plt = pyplot()
        from matplotlib.animation import FuncAnimation, PillowWriter  # matplotlib: only when drawing

        xy_all = np.concatenate([xy for _, xy, _ in self.frames])
        top = max(float(values.max()) for _, _, values in self.frames) or 1.0
        fig, ax = plt.subplots(figsize=(8.0, 3.6))
        fig.subplots_adjust(left=0.08, right=0.98, bottom=0.14, top=0.9)
        first_xy, first_values = self.frames[0][1], self.frames[0][2]
        size = max(2.0, 4000.0 / max(first_xy.shape[0], 1))
        points = ax.scatter(first_xy[:, 0], first_xy[:, 1], c=first_values, s=size, cmap="viridis", vmin=0.0,
                            vmax=top, linewidths=0)
        fig.colorbar(points, ax=ax, label="equivalent plastic strain" if self.colour_by != "displacement"
                     else "displacement (m)")
        pad = 0.02 * float(np.ptp(xy_all[:, 0]) or 1.0)
        ax.set_xlim(xy_all[:, 0].min() - pad, xy_all[:, 0].max() + pad)
        ax.set_ylim(xy_all[:, 1].min() - pad, xy_all[:, 1].max() + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        title = ax.set_title("")

        def draw(i):
            time_s, xy, values = self.frames[i]
            points.set_offsets(xy)
            points.set_array(values)
            title.set_text(f"{self.path.stem}: t = {time_s:.2f} s")
            return points, title

        animation = FuncAnimation(fig, draw, frames=len(self.frames), blit=False)
        tmp = self.path.with_name(self.path.stem + ".tmp.gif")
        animation.save(tmp, writer=PillowWriter(fps=FRAMES_PER_SECOND))
        plt.close(fig)
        tmp.replace(self.path)
        return self.path
