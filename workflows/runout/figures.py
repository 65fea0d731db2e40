"""The figure of a runout stage (PNG): equivalent plastic strain and displacement on the final particle
positions, with the initial ground surface, like Fig. 19 of the ESPFEM2D paper."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from workflows.output.figures import final_state_figure


def runout_fields(stage_path: Path, path: Path, strength_factor: float, polygon_m) -> Path:
    """Draw ``stage_path``'s final state into ``path``, titled with its runout and retrogression, with
    the initial outline ``polygon_m``."""
    outline = np.array(tuple(polygon_m) + (tuple(polygon_m[0]),))

    def title(ds) -> str:
        return (f"strength / {strength_factor:g}, t = {float(ds['time'].values[-1]):.2f} s: runout "
                f"{float(ds['runout_m']):.2f} m, retrogression {float(ds['retrogression_m']):.2f} m")

    def initial_outline(ax, attrs) -> None:
        ax.plot(outline[:, 0], outline[:, 1], "-", color="0.5", lw=0.8)

    return final_state_figure(stage_path, path, title, initial_outline)
