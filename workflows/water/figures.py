"""The study's water drawn over a figure of its domain."""

from __future__ import annotations

import numpy as np

from spfem_core.seepage import phreatic_segments
from workflows.seepage.flow import study_flow


def draw_water(ax, study, x_m: np.ndarray, ground_m: np.ndarray, flow=None) -> None:
    """The piezometric lines (dashed, below the ground), or the phreatic surface of the study's steady
    ``flow`` (solved here when not given) or of its transient water at its time (``flow``, when given),
    and ponded water (solid) in blue over a figure of the
    domain, on the abscissae ``x_m`` where the ground is at ``ground_m``."""
    water = study.water
    if study.transient is not None:  # the water table of the transient flow at the study's time, if given
        if flow is not None:
            for segment in phreatic_segments(flow.node_xy_m, flow.elem_nodes, flow.pressure_head_m):
                ax.plot(segment[:, 0], segment[:, 1], "--", color="tab:blue", lw=1.2)
            for level_m, (x_min, x_max) in flow.reservoir_levels:
                wet = (ground_m < level_m) & (x_m >= x_min) & (x_m <= x_max)
                ax.plot(x_m, np.where(wet, level_m, np.nan), "-", color="tab:blue", lw=1.5)
        return
    if study.seepage is not None:
        flow = study_flow(study) if flow is None else flow
        psi = flow.solution.pressure_head_m(flow.node_xy_m)
        for segment in phreatic_segments(flow.node_xy_m, flow.elem_nodes, psi):
            ax.plot(segment[:, 0], segment[:, 1], "--", color="tab:blue", lw=1.2)
    lines = [] if water is None or water.phreatic_line is None else [water.phreatic_line]
    lines += [m.phreatic_line_m for m in study.materials if m.phreatic_line_m is not None]
    for line in map(np.array, lines):
        ax.plot(x_m, np.minimum(np.interp(x_m, line[:, 0], line[:, 1]), ground_m), "--", color="tab:blue", lw=1.2)
    if water is not None and water.pond_level_m is not None:
        x_min, x_max = water.pond_x_range_m
        wet = (ground_m < water.pond_level_m) & (x_m >= x_min) & (x_m <= x_max)
        ax.plot(x_m, np.where(wet, water.pond_level_m, np.nan), "-", color="tab:blue", lw=1.5)
