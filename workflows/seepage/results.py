"""``seepage.nc``: a study's steady flow, as declared in ``workflows.output.variables.SEEPAGE_FILE``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.seepage import phreatic_segments
from workflows.output.stage_file import provenance
from workflows.output.variables import SEEPAGE_FILE
from workflows.output.writing import write_dataset
from workflows.seepage.figures import draw_seepage

FILE_NAME = "seepage.nc"
FIGURE_NAME = "seepage.png"


def write_seepage(study, dataset: xr.Dataset, out_dir: Path) -> list[Path]:
    """``seepage.nc`` and, with the study's figures, ``seepage.png`` into ``out_dir``; their paths."""
    paths = [write_dataset(dataset.assign_attrs(provenance(study)), Path(out_dir) / FILE_NAME)]
    if study.output.figures:
        paths.append(draw_seepage(dataset, Path(out_dir) / FIGURE_NAME))
    return paths


def flow_line(flow) -> str:
    """The report's line on a flow: the water through the ground, the exit point, the rain that runs off,
    how it settled."""
    solution, inflow = flow.solution, flow.solution.node_inflow_m2_s
    through = float(inflow[(flow.node_condition >= 0) & (inflow > 0.0)].sum())
    exit_x, exit_y = exit_point_m(flow)
    where = f", exit point ({exit_x:.3g}, {exit_y:.3g}) m" if np.isfinite(exit_x) else ""
    runoff = flow.runoff_m2_s()
    off = (f"; {runoff:.3g} m2/s of the rain runs off where the ground is saturated to its surface" if runoff > 0.0
           else "")
    return (f"steady seepage: {through:.3g} m2/s per metre through the ground{where}{off}; settled in "
            f"{solution.iterations} iterations (largest head change {solution.head_change_m[-1]:.2g} m)")


def exit_point_m(flow) -> tuple[float, float]:
    """(x, y) of the highest seepage-face particle water leaves through; NaN without one."""
    problem, solution = flow.problem, flow.solution
    held_face = problem.node_seepage_face & solution.node_held & np.isnan(problem.node_fixed_head_m)
    leaving = held_face & (solution.node_inflow_m2_s < 0.0)
    if not leaving.any():
        return float("nan"), float("nan")
    top = np.flatnonzero(leaving)[np.argmax(flow.node_xy_m[leaving, 1])]
    return float(flow.node_xy_m[top, 0]), float(flow.node_xy_m[top, 1])


def seepage_dataset(study, flow) -> xr.Dataset:
    """The dataset of ``flow`` (a ``workflows.seepage.flow.StudyFlow``) of ``study``."""
    var = SEEPAGE_FILE
    xy, solution = flow.node_xy_m, flow.solution
    psi = solution.pressure_head_m(xy)
    segments = phreatic_segments(xy, flow.elem_nodes, psi)
    inflow = solution.node_inflow_m2_s
    boundary_inflow = np.where(flow.node_condition >= 0, inflow, 0.0)
    data = {
        "particle_x": var["particle_x"](xy[:, 0]),
        "particle_y": var["particle_y"](xy[:, 1]),
        "total_head": var["total_head"](solution.head_m),
        "pressure_head": var["pressure_head"](psi),
        "pore_pressure": var["pore_pressure"](flow.pore_pressure_pa()),
        "particle_inflow": var["particle_inflow"](boundary_inflow),
        "particle_condition": var["particle_condition"](flow.node_condition),
        "mesh2d": var["mesh2d"](np.int32(0), cf_role="mesh_topology", topology_dimension=2,
                                node_coordinates="particle_x particle_y", node_dimension="particle",
                                face_node_connectivity="mesh2d_face_nodes", face_dimension="face"),
        "mesh2d_face_nodes": var["mesh2d_face_nodes"](flow.elem_nodes, cf_role="face_node_connectivity",
                                                      start_index=0),
        "darcy_vx": var["darcy_vx"](solution.elem_darcy_velocity_m_s[:, 0]),
        "darcy_vy": var["darcy_vy"](solution.elem_darcy_velocity_m_s[:, 1]),
        "relative_permeability": var["relative_permeability"](solution.elem_relative_permeability),
        "condition": var["condition"](np.array(flow.conditions, dtype=object)),
        "condition_inflow": var["condition_inflow"](flow.condition_inflow_m2_s()),
        "phreatic_x": var["phreatic_x"](segments[:, :, 0]),
        "phreatic_y": var["phreatic_y"](segments[:, :, 1]),
        "head_change": var["head_change"](np.array(solution.head_change_m)),
    }
    ds = xr.Dataset(data)
    exit_x, exit_y = exit_point_m(flow)
    seepage = study.seepage
    ds.attrs = {
        "title": f"spfem-fos steady seepage of study {study.name}",
        "Conventions": "CF-1.11 UGRID-1.0",
        "study_name": study.name,
        "iterations": int(solution.iterations), "converged": int(bool(solution.converged)),
        "tolerance": float(seepage.tolerance), "residual_permeability": float(seepage.residual_permeability),
        "unsaturated_band_m": float(seepage.unsaturated_band_m),
        "inflow_m2_s": float(boundary_inflow[boundary_inflow > 0].sum()),
        "outflow_m2_s": float(-boundary_inflow[boundary_inflow < 0].sum()),
        "exit_x_m": exit_x, "exit_y_m": exit_y, "runoff_m2_s": flow.runoff_m2_s(),
        "wall_time_s": float(flow.wall_time_s),
        **provenance(study),
    }
    for name in ("particle_x", "particle_y"):
        ds[name].attrs.update(mesh="mesh2d", location="node")
    return ds
