"""Collapse metrics of a finished stage as dataset variables (the study's ``[metrics]``).

Scalars go in as 0-d variables named after the metric keys (units from the key suffix);
the final free-surface profile goes in along a ``surface`` dimension.  Only particles inside
the mesh count: one in flight would raise the surface envelope.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from workflows.collapse_metrics import cohesive_summary, granular_summary, surface_profile
from workflows.study import Metrics

_UNITS_BY_SUFFIX = {"_m": "m", "_deg": "degree", "_m2": "m2"}


def _units(key: str) -> str:
    for suffix, units in sorted(_UNITS_BY_SUFFIX.items(), key=lambda item: -len(item[0])):
        if key.endswith(suffix):
            return units
    return "1"


def metrics_variables(metrics: Metrics, sim) -> dict[str, tuple]:
    """Dataset variables (name -> (dims, values, attrs)) of ``metrics`` on ``sim``'s final state."""
    meshed = np.ones(sim.n_particles, dtype=bool)
    meshed[sim.mesh.orphan_nodes] = False
    xy = sim.node_xy_m[meshed]
    xy0 = sim.node_initial_xy_m[meshed]
    h = sim.scene.spacing_m
    if metrics.kind == "granular_collapse":
        summary = granular_summary(xy, xy0, h, moved_threshold_m=metrics.moved_threshold_m)
    else:
        summary = cohesive_summary(
            xy, xy0, h, sim.node_area_m2[meshed], sim.node_plastic_strain[meshed],
            moved_threshold_m=metrics.moved_threshold_m, plastic_strain_threshold=metrics.plastic_strain_threshold,
        )
    variables = {
        key: ((), float(value), {"units": _units(key), "long_name": f"{metrics.kind} metric {key}"})
        for key, value in summary.items()
    }
    x_m, height_m = surface_profile(xy, h)
    variables["surface_x"] = (("surface",), x_m, {"units": "m", "long_name": "x of the free-surface point"})
    variables["surface_height"] = (
        ("surface",), height_m, {"units": "m", "long_name": "free-surface height (upper envelope of the particles)"}
    )
    return variables


def add_metrics(dataset: xr.Dataset, metrics: Metrics | None, sim) -> xr.Dataset:
    """``dataset`` with the metrics variables added (unchanged when ``metrics`` is None)."""
    if metrics is None:
        return dataset
    for name, (dims, values, attrs) in metrics_variables(metrics, sim).items():
        dataset[name] = xr.Variable(dims, values, attrs)
    dataset.attrs["metrics_kind"] = metrics.kind
    return dataset
