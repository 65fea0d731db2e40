"""The figure of a runout stage (PNG): equivalent plastic strain and displacement on the final particle
positions, with the initial ground surface, like Fig. 19 of the ESPFEM2D paper."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from workflows.fos.figures import final_state_figure


def _initial_outline(ax, study) -> None:
    outline = np.array(study.geometry.polygon_m + (study.geometry.polygon_m[0],))
    ax.plot(outline[:, 0], outline[:, 1], "-", color="0.5", lw=0.8)


def runout_fields(stage_path: Path, path: Path, strength_factor: float) -> Path:
    """Draw ``stage_path``'s final state into ``path``, titled with its runout and retrogression."""

    def title(ds) -> str:
        return (f"strength / {strength_factor:g}, t = {float(ds['time'].values[-1]):.2f} s: runout "
                f"{float(ds['runout_m']):.2f} m, retrogression {float(ds['retrogression_m']):.2f} m")

    return final_state_figure(stage_path, path, title, _initial_outline)
