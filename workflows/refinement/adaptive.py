"""Adaptive refinement: a refined zone along the shear band of a coarse run (``[refinement]``
``adaptive_spacing_m``).

The band is where the first failed run of the coarse level deformed plastically: the particles
whose equivalent plastic strain reaches ``BAND_FRACTION`` of its largest value, at their initial
positions.  Binned in x by the coarse spacing h_0, each bin gives the middle of the band
y_i = (y_min + y_max) / 2, and the zone is the band between y_i - w and y_i + w with

    w = max_i (y_max - y_min) / 2 + margin        (margin: ``band_margin_m``, default h_0)

(the ends extended by a bin, so that the zone reaches the surface where the band comes out).
A band that is not a function of x (a slip surface that turns back) is covered by its bins'
extent, which the vertical half-width then widens.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

BAND_FRACTION = 0.25
"""A particle is in the band when its plastic strain reaches this fraction of the largest."""
MIN_BINS = 3
"""A band over fewer bins of the coarse spacing gives no zone."""


def band_zone(run_path, coarse_spacing_m: float, margin_m: float) -> list[list[float]] | None:
    """The zone polygon (module doc) from the run file ``run_path`` (a stage file with the final
    particle state); None when the run has no band over ``MIN_BINS`` bins."""
    with xr.open_dataset(run_path) as ds:
        x0, y0 = ds["particle_x0"].values, ds["particle_y0"].values
        strain = ds["particle_plastic_strain"].values
    if not strain.size or not np.max(strain) > 0.0:
        return None
    band = strain >= BAND_FRACTION * np.max(strain)
    bins = np.floor(x0[band] / coarse_spacing_m).astype(np.int64)
    keys = np.unique(bins)
    if keys.size < MIN_BINS:
        return None
    x = (keys + 0.5) * coarse_spacing_m
    low = np.array([y0[band][bins == k].min() for k in keys])
    high = np.array([y0[band][bins == k].max() for k in keys])
    middle = 0.5 * (low + high)
    half_width = float(np.max(0.5 * (high - low))) + margin_m
    x = np.concatenate([[x[0] - coarse_spacing_m], x, [x[-1] + coarse_spacing_m]])
    middle = np.concatenate([[middle[0]], middle, [middle[-1]]])
    upper = [[float(a), float(b + half_width)] for a, b in zip(x, middle)]
    lower = [[float(a), float(b - half_width)] for a, b in zip(x[::-1], middle[::-1])]
    return upper + lower
