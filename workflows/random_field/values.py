"""The random fields of ``[random_field]`` (``workflows.random_field.table``) drawn, and their values at the particles.

Each entry of ``[[random_field.properties]]`` makes one property of one material a random field
(Griffiths & Fenton 2004): a standard Gaussian field ``G`` of the entry's correlation model and
scales of fluctuation (``workflows.random_field.embedding``), averaged over each particle's
cell, mapped to the property by

    normal:     X = mean + std G
    lognormal:  X = exp(mu_ln + sigma_ln G),   sigma_ln^2 = ln(1 + cov^2),  mu_ln = ln(mean) - sigma_ln^2 / 2

so that a point of the field has the entry's mean and standard deviation and a particle's value
has the reduced variance of its cell average (for lognormal, the average is taken of ln X, as
RFEM does).  Two properties of one material are cross-correlated through their Gaussian fields,
``G_b = rho G_a + sqrt(1 - rho^2) Z`` with ``Z`` independent of ``G_a`` (one correlation structure for
both, as Fenton & Griffiths' co-located model); for lognormal properties ``rho`` is the
correlation of ln X.

The field of realisation ``r`` with seed ``s`` is drawn from the stream
``SeedSequence([s, r], spawn_key=(FIELD_STREAM, crc32 of the field's name))``, so it depends on nothing
else (not on the other fields, the number of realisations or the worker),
and never coincides with the stream of ``[probabilistic]``'s random variables.  The values live
on the particles (``spfem_core.scene.Scene.node_properties``), and particles are the mesh's
nodes: remeshing never moves a value from one particle to another.
"""

from __future__ import annotations

import math
import zlib

import numpy as np

from workflows.fields import StudyError, specs
from workflows.random_field.embedding import (
    MAX_EMBEDDING,
    EmbeddingError,
    ParticleField,
    ParticleGrid,
    largest_theta_scale,
)
from workflows.random_field.table import ORDERED

FIELD_STREAM = 7
"""The first spawn key of a field's random stream (module doc): apart from every other stream."""


def node_properties(random_field, materials, node_xy_m: np.ndarray, node_spacing_m: np.ndarray,
                    node_material: np.ndarray) -> dict[str, np.ndarray]:
    """property -> (n,) values at the particles (NaN: a particle of another material) of the fields of
    ``random_field`` (a ``workflows.random_field.table.RandomField``) over the study's ``materials`` (module doc)."""
    by_name = {material.name: row for row, material in enumerate(materials)}
    out: dict[str, np.ndarray] = {}
    fields: dict[tuple, ParticleField] = {}
    gaussian: dict[str, np.ndarray] = {}
    entries = random_field.properties
    order = sorted(range(len(entries)), key=lambda k: entries[k].correlated_with is not None)
    for k in order:
        entry = entries[k]
        row = by_name[entry.material]
        mine = np.flatnonzero(node_material == row)
        if mine.size == 0:
            continue
        structure = (row, entry.correlation_model, entry.thetas_m())
        if structure not in fields:
            try:
                theta_x_m, theta_y_m = entry.thetas_m()
                fields[structure] = ParticleField(entry.model(), theta_x_m, theta_y_m, node_xy_m[mine, 0],
                                                  node_xy_m[mine, 1], node_spacing_m[mine])
            except EmbeddingError:
                raise _too_long(random_field, k, ParticleGrid.of(node_xy_m[mine, 0], node_xy_m[mine, 1],
                                                                 node_spacing_m[mine])) from None
        stream = np.random.SeedSequence([random_field.seed, random_field.realisation],
                                        spawn_key=(FIELD_STREAM, zlib.crc32(entry.name.encode())))
        g = fields[structure].draw(np.random.default_rng(stream))[0]
        if entry.correlated_with is not None:
            rho = entry.correlation
            g = rho * gaussian[entry.correlated_with] + math.sqrt(1.0 - rho * rho) * g
        gaussian[entry.name] = g
        mean, std = random_field.moments(entry, materials[row])
        values = entry.law().field_values(mean, std, g)
        spec = specs(type(materials[row]))[entry.property]
        for op, bound in spec.bounds:  # a normal field's rare values beyond its range (OUTSIDE_RANGE_LIMIT)
            limit = {">": np.nextafter(bound, math.inf), "<": np.nextafter(bound, -math.inf)}.get(op, bound)
            values = np.maximum(values, limit) if op in (">", ">=") else np.minimum(values, limit)
        column = out.setdefault(entry.property, np.full(node_xy_m.shape[0], np.nan))
        column[mine] = values
    keep_order(materials, node_material, out)
    return out


def keep_order(materials, node_material: np.ndarray, out: dict[str, np.ndarray]) -> None:
    """The lower property of each order (:data:`ORDERED`) set to the upper at the particles whose
    fields break it (rare: ``RandomField._check_order``), in ``out`` (NaN: a particle of
    another material)."""
    for lower, upper in ORDERED:
        if lower not in out and upper not in out:
            continue
        for row, material in enumerate(materials):
            if any(getattr(material, prop, None) is None for prop in (lower, upper)):
                continue
            mine = node_material == row
            values = {prop: np.where(np.isnan(out[prop][mine]), getattr(material, prop), out[prop][mine])
                      if prop in out else np.full(int(mine.sum()), float(getattr(material, prop)))
                      for prop in (lower, upper)}
            broken = values[lower] > values[upper]
            if broken.any():
                column = out.setdefault(lower, np.full(node_material.shape[0], np.nan))
                column[mine] = np.where(broken, values[upper], column[mine])


def _too_long(random_field, k: int, grid: ParticleGrid) -> StudyError:
    """The refusal of entry ``k``'s scales of fluctuation, too long for the circulant embedding on the
    grid of its material's particles: the field named, the longest scales this section holds."""
    entry = random_field.properties[k]
    theta_x_m, theta_y_m = entry.thetas_m()
    scale = largest_theta_scale(entry.model(), theta_x_m, theta_y_m, grid)
    lx, ly = grid.extent_m
    field = "theta_y_m" if entry.theta_y_m is not None and theta_y_m / ly > theta_x_m / lx else "theta_x_m"
    longest = (f"theta_x_m up to {scale * theta_x_m:.2g} m" if entry.theta_y_m is None else
               f"theta_x_m up to {scale * theta_x_m:.2g} m with theta_y_m {scale * theta_y_m:.2g} m (in this "
               "ratio)")
    return StudyError(f"random_field.properties[{k}].{field}", (
        f"{entry.name!r}: a {entry.correlation_model} field with theta = ({theta_x_m:g}, {theta_y_m:g}) m over "
        f"{entry.material!r} ({lx:.3g} m by {ly:.3g} m) has no circulant embedding of up to {MAX_EMBEDDING} "
        f"times its grid; this section holds {longest}; a longer scale of fluctuation needs another method "
        "(not yet)"))
