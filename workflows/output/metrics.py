"""Collapse metrics of a finished stage as dataset variables (the study's ``[metrics]``).

Scalars go in as 0-d variables named after the metric keys, the final free-surface profile
along a ``surface`` dimension; units and long names from
:data:`workflows.output.variables.COLLAPSE_METRICS`.  Only particles inside the mesh count:
one in flight would raise the surface envelope.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from workflows.collapse.metrics import cohesive_summary, granular_summary, surface_profile
from workflows.fos.scales import slope_height_m
from workflows.output.variables import COLLAPSE_METRICS, RUNOUT_METRICS
from workflows.runout.metrics import final_surface, runout_summary
from workflows.study import Metrics, RunoutStage, Study


def _in_mesh(sim) -> np.ndarray:
    """True for the particles in the final mesh (one in flight would raise the surface envelope)."""
    meshed = np.ones(sim.n_particles, dtype=bool)
    meshed[sim.mesh.orphan_nodes] = False
    return meshed


def metrics_variables(metrics: Metrics, sim) -> dict[str, tuple]:
    """Dataset variables (name -> (dims, values, attrs)) of ``metrics`` on ``sim``'s final state."""
    meshed = _in_mesh(sim)
    xy = sim.nodes.xy_m[meshed]
    xy0 = sim.initial_xy_m[meshed]
    h = sim.scene.spacing_m
    if metrics.kind == "granular_collapse":
        summary = granular_summary(xy, xy0, h, moved_threshold_m=metrics.moved_threshold_m)
    else:
        summary = cohesive_summary(
            xy, xy0, h, sim.node_area_m2[meshed], sim.nodes.plastic_strain[meshed],
            moved_threshold_m=metrics.moved_threshold_m, plastic_strain_threshold=metrics.plastic_strain_threshold,
        )
    variables = {key: COLLAPSE_METRICS[key](float(value)) for key, value in summary.items()}
    x_m, height_m = surface_profile(xy, h)
    variables["surface_x"] = COLLAPSE_METRICS["surface_x"](x_m)
    variables["surface_height"] = COLLAPSE_METRICS["surface_height"](height_m)
    return variables


def add_metrics(dataset: xr.Dataset, metrics: Metrics | None, sim) -> xr.Dataset:
    """``dataset`` with the metrics variables added (unchanged when ``metrics`` is None)."""
    if metrics is None:
        return dataset
    for name, (dims, values, attrs) in metrics_variables(metrics, sim).items():
        dataset[name] = xr.Variable(dims, values, attrs)
    dataset.attrs["metrics_kind"] = metrics.kind
    return dataset


DEFAULT_DEPOSIT_THICKNESS = 0.02
"""Default deposit thickness of a runout stage, as a fraction of the slope height."""
DEFAULT_MOVED_FRACTION = 0.01
"""Default moved threshold of a runout stage, as a fraction of the slope height."""


def add_runout_metrics(dataset: xr.Dataset, study: Study, stage: RunoutStage, series, sim) -> xr.Dataset:
    """``dataset`` with the runout metrics (``workflows.runout.metrics``) of ``stage`` added."""
    meshed = _in_mesh(sim)
    height = slope_height_m(study)
    thickness = stage.deposit_thickness_m or DEFAULT_DEPOSIT_THICKNESS * height
    moved = stage.moved_threshold_m or DEFAULT_MOVED_FRACTION * height
    initial_area = sim.nodes.mass_kg / sim.scene.particle_density_kg_m3
    summary = runout_summary(
        study.geometry.polygon_m, sim.nodes.xy_m[meshed], sim.nodes.displacement_m, initial_area, sim.scene.spacing_m,
        series.time_s, series.energy_j_per_m, series.max_speed_m_s, deposit_thickness_m=thickness,
        moved_threshold_m=moved, rest_fraction=stage.rest_fraction, rest_window_s=stage.rest_window_s,
    )
    for key, value in summary.items():
        dataset[key] = xr.Variable(*RUNOUT_METRICS[key](value))
    x_m, height_m = final_surface(sim.nodes.xy_m[meshed], sim.scene.spacing_m)
    dataset["surface_x"] = xr.Variable(*RUNOUT_METRICS["surface_x"](x_m))
    dataset["surface_height"] = xr.Variable(*RUNOUT_METRICS["surface_height"](height_m))
    dataset.attrs["metrics_kind"] = "runout"
    return dataset
