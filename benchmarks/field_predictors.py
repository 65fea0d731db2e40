"""How well a random-field realisation's FOS is predicted from what is known before its search, measured
offline on the results of a probabilistic study in fos mode (nothing is run).

    python -m workflows.cli <probabilistic_undrained.toml with compute = "fos"> --out /tmp/rf
    python -m benchmarks.field_predictors /tmp/rf

Each realisation's FOS and slip line come from its ``summary.nc``, its fields from its ``case.toml``.
A realisation is predicted as the study predicts it (``fos.prediction.FosPredictor``: its estimate E
times the mean ratio F / E of the realisations of the earlier generations, ``Generations`` of 1, 2,
4, ... 32), from these estimates E:

- ``circles, all``: the shipped one (``probabilistic.field_mechanisms.FieldCircles``), the least over every
  admissible circle of the mean soil of its F times the field's mean along its arc over the field's mean;
- ``circles, 400 least`` and ``circles, 40 least``: the same over the least circles of the mean soil only;
- ``slip lines, 10% quantile``: the estimate before, over the slip lines of the earlier generations'
  realisations, F_j times the ratio of the field's mean along j's line (at equal steps of x) to j's own,
  the 10% quantile over j (the least circles while none is known); ``slip lines, least``: their least.

The table: the relative rms of (prediction - FOS) / FOS and its mean, over the realisations from the
fourth on and from the 32nd on (realisations whose FOS was not found are left out).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.spatial import cKDTree

from workflows.fos.critical_circle import candidate_circles
from workflows.fos.prediction import FosPredictor, Generations
from workflows.probabilistic.field_mechanisms import ARC_POINTS, FieldCircles, arc_points_m
from workflows.random_field.table import RandomField
from workflows.random_field.values import node_properties
from workflows.scene import assign_materials, cloud
from workflows.study import load_study

LINE_POINTS = 80


def generation_starts(count: int, largest: int = 32) -> list[int]:
    """The first realisation of each realisation's generation (``Generations``)."""
    generations, starts = Generations(count, largest), []
    while generations.given < count:
        start, room = generations.given, generations.room(generations.given)
        generations.take(room)
        starts += [start] * room
    return starts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.field_predictors", description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the output folder of a random-field probabilistic study in fos mode")
    args = parser.parse_args(argv)
    folders = sorted((args.out / "cases").iterdir())
    studies = [load_study(folder / "case.toml") for folder in folders]
    base = studies[0]
    node_xy_m, node_spacing_m = cloud(base)
    tree = cKDTree(node_xy_m)
    [entry] = base.random_field.properties  # one cohesive field (the undrained study)
    mean, _ = RandomField.moments(entry, next(m for m in base.materials if m.name == entry.material))
    fields = [node_properties(study.random_field, study.materials, node_xy_m, node_spacing_m,
                              assign_materials(study, node_xy_m))[entry.property] for study in studies]
    fos, lines = [], []
    for folder in folders:
        with xr.open_dataset(folder / "summary.nc") as ds:
            fos.append(float(ds["fos"]))
            x, y = np.asarray(ds["slip_x"].values, float), np.asarray(ds["slip_y"].values, float)
        if x.size < 2:
            lines.append(None)
            continue
        order = np.argsort(x)
        along_x = np.linspace(x.min(), x.max(), LINE_POINTS)
        lines.append(tree.query(np.column_stack([along_x, np.interp(along_x, x[order], y[order])]))[1])
    fos_found = np.array(fos)
    n = len(folders)
    starts = generation_starts(n)

    shipped = FieldCircles(base)
    circles = candidate_circles(base, 400)
    least_along = np.array([tree.query(arc_points_m(circle))[1] for circle in circles]).reshape(len(circles), ARC_POINTS)
    least_fos = np.array([circle.fos for circle in circles])

    def least_circles(i: int, count: int) -> float:
        return float(np.min(least_fos[:count] * fields[i][least_along[:count]].mean(axis=1) / mean))

    def slip_lines(i: int, how) -> float:
        known = [j for j in range(starts[i]) if lines[j] is not None and math.isfinite(fos_found[j])]
        if not known:
            return least_circles(i, 40)
        return float(how([fos_found[j] * fields[i][lines[j]].mean() / fields[j][lines[j]].mean() for j in known]))

    estimates = {
        "circles, all (shipped)": [shipped.estimate(study) for study in studies],
        "circles, 400 least": [least_circles(i, 400) for i in range(n)],
        "circles, 40 least": [least_circles(i, 40) for i in range(n)],
        "slip lines, 10% quantile (before)": [slip_lines(i, lambda v: np.quantile(v, 0.1)) for i in range(n)],
        "slip lines, least": [slip_lines(i, np.min) for i in range(n)],
    }
    print(f"{n} realisations, {int(np.isfinite(fos_found).sum())} FOS found (mean {np.nanmean(fos_found):.4f}, "
          f"std {np.nanstd(fos_found, ddof=1):.4f})")
    print("| estimate E | rms, from the 4th | mean | rms, from the 32nd | mean |")
    print("|---|---|---|---|---|")
    for name, values in estimates.items():
        errors = []
        for i in range(n):
            predictor = FosPredictor()
            for j in range(starts[i]):
                predictor.observe([], values[j], fos_found[j])
            prediction = predictor.predict([], values[i])
            errors.append((prediction.fos - fos_found[i]) / fos_found[i] if prediction is not None else math.nan)
        error = np.array(errors)
        cells = []
        for first in (3, 31):
            tail = error[first:][np.isfinite(error[first:])]
            cells += [f"{math.sqrt(np.mean(tail ** 2)):.4f}", f"{np.mean(tail):+.4f}"]
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
