"""A slope's intensity-duration threshold: from a sweep of a ``[transient]`` study over the time of
its water (``transient.water_at_h``) and one other axis (a rain intensity, a drawdown rate), the time
at which the FOS falls to 1 for each value of the other axis (``threshold.nc``, ``threshold.png``).

Along the swept times t_1 < t_2 < ... the FOS F_k (NaN where a case found none: its bound from its runs,
the lowest failed SRF, or +inf when every run was stable) first falls below 1 between t_k-1 and t_k:
the threshold is t_k-1 + (t_k - t_k-1)(F_k-1 - 1)/(F_k-1 - F_k) (the first time if F_1 < 1; NaN, no
threshold within the swept times, if it never does).  Rain longer than the threshold at that
intensity fails the slope.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.fos_time.results import time_fos_reaches
from workflows.output.figures import pyplot, save_figure
from workflows.output.stage_file import provenance
from workflows.output.variables import THRESHOLD_FILE
from workflows.output.writing import write_dataset
from workflows.study.reading import axis_labels

TIME_AXIS = "transient.water_at_h"
FILE_NAME = "threshold.nc"
FIGURE_NAME = "threshold.png"


def applies(study) -> bool:
    """A grid sweep of a ``[transient]`` study over ``transient.water_at_h`` and exactly one other axis."""
    sweep = study.sweep
    return (study.transient is not None and sweep is not None and study.strength_reduction is not None
            and sweep.combination == "grid" and len(sweep.axes) == 2
            and sum(axis.path == TIME_AXIS for axis in sweep.axes) == 1)


def threshold_dataset(study, sweep_dataset: xr.Dataset) -> xr.Dataset:
    """``threshold.nc`` from the sweep's ``study.nc`` (module doc)."""
    labels = axis_labels(study.sweep)
    time_label = labels[[axis.path for axis in study.sweep.axes].index(TIME_AXIS)]
    other = next(label for label in labels if label != time_label)
    fos = sweep_dataset["fos"].transpose(other, time_label)
    high = sweep_dataset["fos_high"].transpose(other, time_label).values
    times = sweep_dataset[time_label].values.astype(float)
    order = np.argsort(times)
    durations, lowest = [], []
    for row, row_high in zip(fos.values, high):
        values = [f if math.isfinite(f) else (h if math.isfinite(h) else math.inf) for f, h in zip(row, row_high)]
        values = [values[k] for k in order]
        durations.append(time_fos_reaches(list(times[order]), values, 1.0))
        finite = [v for v in values if math.isfinite(v)]
        lowest.append(min(finite) if finite else math.nan)
    var = THRESHOLD_FILE
    ds = xr.Dataset(coords={other: sweep_dataset[other]})
    ds["duration_to_fos_1"] = var["duration_to_fos_1"].over((other,), np.array(durations))
    ds["lowest_fos"] = var["lowest_fos"].over((other,), np.array(lowest))
    ds.attrs = {"title": f"spfem-fos threshold of study {study.name}: the time at which the FOS falls to 1",
                "study_name": study.name, "time_axis": time_label, "other_axis": other, **provenance(study)}
    return ds


def write_threshold(study, sweep_dataset: xr.Dataset, out_dir: Path) -> list[Path]:
    """``threshold.nc`` and, with the study's figures, ``threshold.png``; their paths."""
    ds = threshold_dataset(study, sweep_dataset)
    paths = [write_dataset(ds, Path(out_dir) / FILE_NAME)]
    if study.output.figures:
        paths.append(draw_threshold(ds, Path(out_dir) / FIGURE_NAME))
    return paths


def draw_threshold(ds: xr.Dataset, path: Path) -> Path:
    """The other axis (a rain intensity) against the duration at which the FOS falls to 1."""
    plt = pyplot()
    other = ds.attrs["other_axis"]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    durations = ds["duration_to_fos_1"].values
    try:  # a rain intensity; a value that is no number (a drawdown's hydrograph) at its position, labelled
        values, labels = ds[other].values.astype(float), None
    except (TypeError, ValueError):
        values, labels = np.arange(ds[other].size, dtype=float), [str(v) for v in ds[other].values]
    found = np.isfinite(durations)
    ax.plot(durations[found], values[found], "o-", color="tab:red", label="FOS = 1")
    for value in values[~found]:
        ax.annotate("stays above 1", (0.98, value), xycoords=("axes fraction", "data"), ha="right", fontsize=8)
    if labels is not None:
        ax.set_yticks(values, labels, fontsize=7)
    ax.set_xlabel("time of the water (h) at which the FOS falls to 1")
    ax.set_ylabel(other)
    ax.set_title("the time at which the FOS falls to 1 (for rain: longer rain at that intensity fails the slope)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
