"""The random fields of ``[random_field]`` (``workflows.random_field.table``) drawn, and their values at the particles.

Each entry of ``[[random_field.properties]]`` makes one property of one material a random field
(Griffiths & Fenton 2004): a standard Gaussian field ``G`` of the entry's correlation model and
scales of fluctuation (circulant embedding, ``workflows.random_field.embedding``; where none holds the
scales, a Karhunen-Loeve expansion, or one value per realisation beyond a multiple of the section:
``workflows.random_field.expansion``, :func:`particle_field`), averaged over each particle's
cell, mapped to the property by

    normal:     X = mean + std G
    lognormal:  X = exp(mu_ln + sigma_ln G),   sigma_ln^2 = ln(1 + cov^2),  mu_ln = ln(mean) - sigma_ln^2 / 2

so that a point of the field has the entry's mean and standard deviation and a particle's value
has the reduced variance of its cell average (for lognormal, the average is taken of ln X, as
RFEM does).  Two properties of one material are cross-correlated through their Gaussian fields,
``G_b = rho G_a + sqrt(1 - rho^2) Z`` with ``Z`` independent of ``G_a`` (one correlation structure for
both, as Fenton & Griffiths' co-located model); for lognormal properties ``rho`` is the
correlation of ln X.

The field of realisation ``r`` with seed ``s`` is the generator's linear map of a standard normal vector
xi (``field_of``) drawn from the stream
``SeedSequence([s, r], spawn_key=(FIELD_STREAM, crc32 of the field's name))``, so it depends on nothing
else (not on the other fields, the number of realisations or the worker),
and never coincides with the stream of ``[probabilistic]``'s random variables; with ``combination``, xi is
the weighted sum of the vectors of the realisations it names (:func:`standard_normals`).  The values live
on the particles (``spfem_core.scene.Scene.node_properties``), and particles are the mesh's
nodes: remeshing never moves a value from one particle to another.
"""

from __future__ import annotations

import functools
import math
import zlib
from typing import Any

import numpy as np

from workflows.fields import specs
from workflows.random_field.correlation import CorrelationModel
from workflows.random_field.embedding import EmbeddingError, ParticleField
from workflows.random_field.expansion import (
    SINGLE_VARIABLE_MULTIPLE,
    ExpandedField,
    SingleValueField,
    single_variable_limit,
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
    fields: dict[tuple, Any] = {}
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
            theta_x_m, theta_y_m = entry.thetas_m()
            fields[structure] = particle_field(entry.model(), theta_x_m, theta_y_m, node_xy_m[mine],
                                               node_spacing_m[mine])
        g = fields[structure].field_of(standard_normals(fields[structure], random_field, entry.name))
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


def standard_normals(generator, random_field, name: str) -> np.ndarray:
    """The standard normal vector xi of the field ``name`` in the realisation of ``random_field``: that of the
    realisation's own stream (module doc), or the weighted sum of those of the realisations its ``combination``
    names (a Markov chain's move: the field of the sum is the sum of the fields, the map xi -> field linear)."""
    xi = 0.0
    for realisation, weight in random_field.terms():  # (1.0 times one vector: that vector, bit for bit)
        stream = np.random.SeedSequence([random_field.seed, realisation],
                                        spawn_key=(FIELD_STREAM, zlib.crc32(name.encode())))
        xi = xi + weight * generator.standard_normals(np.random.default_rng(stream))
    return np.asarray(xi)


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


def particle_field(model: CorrelationModel, theta_x_m: float, theta_y_m: float, xy_m: np.ndarray, spacing_m: np.ndarray):
    """The generator of a field's cell averages at the particles ``xy_m`` (module doc): one value per
    realisation beyond :data:`~workflows.random_field.expansion.SINGLE_VARIABLE_MULTIPLE` times the section,
    otherwise circulant embedding (exact), or where no embedding holds the scales the Karhunen-Loeve
    expansion (``workflows.random_field.expansion``); made once per process for one cloud and model."""
    xy_m, spacing_m = np.ascontiguousarray(xy_m, float), np.ascontiguousarray(np.broadcast_to(spacing_m, len(xy_m)),
                                                                              float)
    return _particle_field(model, float(theta_x_m), float(theta_y_m), xy_m.tobytes(), spacing_m.tobytes())


@functools.lru_cache(maxsize=4)  # a study's realisations on one process share the cloud and its generator
def _particle_field(model: CorrelationModel, theta_x_m: float, theta_y_m: float, xy_bytes: bytes, spacing_bytes: bytes):
    xy_m = np.frombuffer(xy_bytes).reshape(-1, 2)
    spacing_m = np.frombuffer(spacing_bytes)
    extent_m = np.ptp(xy_m, axis=0) + spacing_m.max()  # the cells' bounding box
    if single_variable_limit(theta_x_m, theta_y_m, *extent_m):
        return SingleValueField(len(xy_m))
    try:
        return ParticleField(model, theta_x_m, theta_y_m, xy_m[:, 0], xy_m[:, 1], spacing_m)
    except EmbeddingError:
        return ExpandedField(model, theta_x_m, theta_y_m, xy_m[:, 0], xy_m[:, 1], spacing_m)


def field_notes(random_field, materials, node_xy_m: np.ndarray, node_spacing_m: np.ndarray,
                node_material: np.ndarray) -> list[str]:
    """A line per field not drawn exactly by circulant embedding: the single-variable limit, or the
    expansion with the share of the cells' variance it keeps (module doc of
    ``workflows.random_field.expansion``)."""
    by_name = {material.name: row for row, material in enumerate(materials)}
    lines = []
    for entry in random_field.properties:
        mine = np.flatnonzero(node_material == by_name[entry.material])
        if mine.size == 0 or entry.correlated_with is not None:
            continue
        theta_x_m, theta_y_m = entry.thetas_m()
        field = particle_field(entry.model(), theta_x_m, theta_y_m, node_xy_m[mine], node_spacing_m[mine])
        where = (f"random field {entry.name!r} (theta = ({theta_x_m:g}, {theta_y_m:g}) m over {entry.material!r})")
        if isinstance(field, SingleValueField):
            lines.append(f"note: {where}: theta is over {SINGLE_VARIABLE_MULTIPLE:g} times the section, so the field is "
                         "one value per realisation (the single-variable limit)")
        elif isinstance(field, ExpandedField):
            kept = field.variance_kept
            lines.append(f"note: {where}: no circulant embedding holds theta on this section; drawn by a "
                         f"Karhunen-Loeve expansion ({field.n_modes} modes on {field.n_nodes} nodes) that keeps "
                         f"{100 * kept.mean():.1f}% of the cells' variance (at least {100 * kept.min():.1f}%)")
    return lines
