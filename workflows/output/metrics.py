"""Collapse metrics of a finished stage as dataset variables (the study's ``[metrics]``).

Scalars go in as 0-d variables named after the metric keys, the final free-surface profile
along a ``surface`` dimension; units and long names from
:data:`workflows.output.variables.COLLAPSE_METRICS`.  Only particles inside the mesh count:
one in flight would raise the surface envelope.  (A runout stage's own metrics:
``workflows.stages.runout``.)
"""

from __future__ import annotations

from workflows.collapse.metrics import surface_profile
from workflows.output.variables import COLLAPSE_METRICS


def metrics_variables(metrics, final) -> dict[str, tuple]:
    """Dataset variables (name -> (dims, values, attrs)) of ``metrics`` (the study's ``Metrics``) on
    the final particles ``final`` (a ``spfem_core.snapshot.Snapshot``)."""
    meshed = final.meshed
    xy = final.xy_m[meshed]
    xy0 = final.initial_xy_m[meshed]
    h = final.spacing_m
    summary = metrics.collapse.summary(metrics, xy, xy0, h, final.area_m2[meshed], final.plastic_strain[meshed])
    variables = {key: COLLAPSE_METRICS[key](float(value)) for key, value in summary.items()}
    x_m, height_m = surface_profile(xy, h)
    variables["surface_x"] = COLLAPSE_METRICS["surface_x"](x_m)
    variables["surface_height"] = COLLAPSE_METRICS["surface_height"](height_m)
    return variables


def add_metrics(dataset, metrics, final) -> None:
    """Add the variables of ``metrics`` to ``dataset`` (nothing when ``metrics`` is None)."""
    if metrics is None:
        return
    for name, variable in metrics_variables(metrics, final).items():
        dataset[name] = variable
    dataset.attrs["metrics_kind"] = metrics.kind
