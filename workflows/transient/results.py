"""``transient.nc``: a study's transient flow at each saved time, as declared in
``workflows.output.variables.TRANSIENT_FILE``; the rain and the reservoir's level at times."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from spfem_core.transient_seepage import FluxBoundary, ReservoirBoundary
from workflows.output.stage_file import provenance
from workflows.output.variables import TRANSIENT_FILE
from workflows.output.writing import write_dataset
from workflows.transient.table import HOUR_S, MM_H_TO_M_S

FILE_NAME = "transient.nc"


def _first(flow, kind):
    return next((b for b in flow.problem.boundaries if isinstance(b, kind)), None)


def rain_mm_h(flow, times_h) -> np.ndarray:
    """The intensity (mm/h) of the first rain condition at each time, less its evaporation (0 without rain)."""
    rain = _first(flow, FluxBoundary)
    return np.array([0.0 if rain is None else rain.flux_m_s.at(t * HOUR_S) / MM_H_TO_M_S for t in times_h])


def cumulative_rain_mm(flow, times_h) -> np.ndarray:
    """The rain (mm) of the first rain condition fallen since t = 0, less its evaporation, at each time."""
    rain = _first(flow, FluxBoundary)
    if rain is None:
        return np.zeros(len(times_h))
    return np.array([0.0 if t <= 0.0 else rain.flux_m_s.mean(0.0, t * HOUR_S) * t * HOUR_S * 1e3 for t in times_h])


def reservoir_level_m(flow, times_h) -> np.ndarray:
    """The reservoir's level at each time (NaN without one)."""
    reservoir = _first(flow, ReservoirBoundary)
    return np.array([math.nan if reservoir is None else reservoir.level_m.at(t * HOUR_S) for t in times_h])


def transient_dataset(study, flow) -> xr.Dataset:
    """The dataset of ``flow`` (``workflows.transient.flow.TransientFlow``) of ``study``."""
    var = TRANSIENT_FILE
    solution, xy = flow.solution, flow.node_xy_m
    times_h = solution.times_s / HOUR_S
    pore = np.array([flow.water_at(t).pore_pressure_pa() for t in times_h])
    data = {
        "time": var["time"](times_h),
        "particle_x": var["particle_x"](xy[:, 0]),
        "particle_y": var["particle_y"](xy[:, 1]),
        "mesh2d": var["mesh2d"](np.int32(0), cf_role="mesh_topology", topology_dimension=2,
                                node_coordinates="particle_x particle_y", node_dimension="particle",
                                face_node_connectivity="mesh2d_face_nodes", face_dimension="face"),
        "mesh2d_face_nodes": var["mesh2d_face_nodes"](flow.elem_nodes, cf_role="face_node_connectivity",
                                                      start_index=0),
        "total_head": var["total_head"](solution.head_m),
        "pressure_head": var["pressure_head"](solution.pressure_head_m(xy)),
        "water_content": var["water_content"](solution.water_content),
        "effective_saturation": var["effective_saturation"](solution.effective_saturation),
        "pore_pressure": var["pore_pressure"](pore),
        "held": var["held"](solution.node_held.astype(np.int8)),
        "darcy_vx": var["darcy_vx"](solution.elem_darcy_velocity_m_s[:, :, 0]),
        "darcy_vy": var["darcy_vy"](solution.elem_darcy_velocity_m_s[:, :, 1]),
        "condition": var["condition"](np.array(solution.boundary_names, dtype=object)),
        "condition_inflow": var["condition_inflow"](solution.boundary_inflow_m2_s),
        "condition_cumulative_inflow": var["condition_cumulative_inflow"](solution.boundary_cumulative_inflow_m2),
        "water_in": var["water_in"](solution.water_in_m2),
        "water_out": var["water_out"](solution.water_out_m2),
        "stored_water": var["stored_water"](solution.stored_water_m2),
        "balance_error": var["balance_error"](solution.balance_error_m2),
        "balance_fraction": var["balance_fraction"](solution.balance_fraction()),
        "rain_intensity": var["rain_intensity"](rain_mm_h(flow, times_h)),
        "reservoir_level": var["reservoir_level"](reservoir_level_m(flow, times_h)),
        "step_end_time": var["step_end_time"](solution.step_end_s),
        "step_length": var["step_length"](solution.step_s),
        "step_iterations": var["step_iterations"](solution.step_iterations),
    }
    ds = xr.Dataset(data)
    steps = solution.step_balance_fractions()
    ds.attrs = {
        "title": f"spfem-fos transient flow of study {study.name}",
        "Conventions": "CF-1.11 UGRID-1.0",
        "study_name": study.name,
        "largest_balance_fraction": float(solution.balance_fraction().max()),
        "largest_step_balance_fraction": float(steps.max()) if steps.size else 0.0,
        "steps": int(solution.step_s.size), "rejected_steps": int(solution.rejected_steps),
        "solves": int(solution.solves), "factorizations": int(solution.factorizations),
        "wall_time_s": float(flow.wall_time_s),
        **provenance(study),
    }
    for name in ("particle_x", "particle_y"):
        ds[name].attrs.update(mesh="mesh2d", location="node")
    return ds


def write_transient(study, flow, out_dir: Path) -> Path:
    """``transient.nc`` into ``out_dir``; its path."""
    return write_dataset(transient_dataset(study, flow), Path(out_dir) / FILE_NAME)


def balance_line(flow) -> str:
    """The report's line on the flow's mass balance."""
    solution = flow.solution
    stored = solution.stored_water_m2[-1] - solution.stored_water_m2[0]
    steps = solution.step_balance_fractions()
    return (f"transient flow to {solution.times_s[-1] / HOUR_S:g} h: {solution.step_s.size} steps "
            f"({solution.rejected_steps} rejected), {flow.wall_time_s:.1f} s; water in {solution.water_in_m2[-1]:.4g} "
            f"m2/m, out {solution.water_out_m2[-1]:.4g}, stored {stored:+.4g}: mass balance closed to "
            f"{solution.balance_fraction().max():.1e} (worst step {steps.max() if steps.size else 0.0:.1e})")
