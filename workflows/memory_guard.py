"""Refuse a study the machine cannot hold, before a single particle is made.

The particle count of ``geometry`` is estimated from the polygon: n ~ A / h^2 + P / h (the
lattice inside and the particles on the edges; A the area, P the perimeter, h the spacing).
A process holding a simulation needs about ``BYTES_PER_PARTICLE`` per particle at its peak
(state, mesh, work arrays and Qhull's temporaries during a rebuild: 2.6-3.2 kB of peak resident
memory on the reference slope at 240k and 60k particles, ``python -m
benchmarks.memory_per_particle``), and an FOS
study holds one in its own process and one in each local worker.  A study whose estimate
exceeds the limit (by default the memory the machine has available now) is refused with one
line that names the spacing that makes most of its particles: ``geometry.spacing_m`` or a refined
zone's.
"""

from __future__ import annotations

import math

import numpy as np
import psutil

from spfem_core.cloud import spacing_field
from spfem_core.geometry import ray_casting_inside
from workflows.study import Study, StudyError

BYTES_PER_PARTICLE = 3200
"""Peak memory of one process per particle (module doc)."""

GIB = 1024.0**3


def estimated_particles(study: Study) -> float:
    """n ~ A / h^2 + P / h for the polygon of ``study.geometry`` (inf when h underflows); with refined
    zones, the integral of 1 / h(x)^2 over the domain on a grid of the coarse spacing, plus P / h_min."""
    if study.geometry.refined:
        return _graded_estimate(study)
    vertices = study.geometry.polygon_m
    h = study.geometry.spacing_m
    area = 0.5 * abs(sum(x1 * y2 - x2 * y1 for (x1, y1), (x2, y2) in zip(vertices, vertices[1:] + vertices[:1])))
    perimeter = sum(math.hypot(x2 - x1, y2 - y1) for (x1, y1), (x2, y2) in zip(vertices, vertices[1:] + vertices[:1]))
    with_lattice = area / (h * h) if h * h > 0.0 else math.inf
    return with_lattice + perimeter / h


def _graded_estimate(study: Study) -> float:
    geometry = study.geometry
    polygon = np.array(geometry.polygon_m)
    finest = geometry.finest_spacing_m
    if not finest > 0.0 or not np.isfinite((np.ptp(polygon, axis=0) / finest).prod()):
        return math.inf
    cell_m2, fields = _spacing_fields(study)
    perimeter = float(np.hypot(*np.diff(np.vstack([polygon, polygon[:1]]), axis=0).T).sum())
    return float(np.sum(cell_m2 / fields.min(axis=0) ** 2)) + perimeter / finest


def _spacing_fields(study: Study) -> tuple[float, np.ndarray]:
    """(the area of a cell of the grid, h(x) on the grid inside the polygon for the coarse spacing
    and for each refined zone alone, a row each: h(x) of the cloud is their minimum)."""
    geometry = study.geometry
    polygon = np.array(geometry.polygon_m)
    h0 = geometry.spacing_m
    step = min(h0, np.ptp(polygon, axis=0).min() / 20.0)
    x = np.arange(polygon[:, 0].min() + 0.5 * step, polygon[:, 0].max(), step)
    y = np.arange(polygon[:, 1].min() + 0.5 * step, polygon[:, 1].max(), step)
    grid = np.column_stack([a.ravel() for a in np.meshgrid(x, y)])
    inside = grid[ray_casting_inside(grid, polygon)]
    fields = [np.full(len(inside), h0)]
    fields += [spacing_field(inside, h0, [zone], geometry.grading) for zone in geometry.zones]
    return step * step, np.array(fields)


def spacing_to_blame(study: Study) -> tuple[str, float]:
    """(field, spacing) of the spacing that makes most of the particles: ``geometry.spacing_m``, or a
    refined zone's (``geometry.refined[i].spacing_m``, the finest zone's if the count overflows)."""
    geometry = study.geometry
    fields = [("geometry.spacing_m", geometry.spacing_m)] + [
        (f"geometry.refined[{i}].spacing_m", zone.spacing_m) for i, zone in enumerate(geometry.refined)]
    if not geometry.refined:
        return fields[0]
    if not math.isfinite(_graded_estimate(study)):
        return min(fields, key=lambda field: field[1])
    _, spacings = _spacing_fields(study)
    governing = np.argmin(spacings, axis=0)  # the coarse spacing where no zone makes it finer
    particles = [np.sum(1.0 / spacings[k, governing == k] ** 2) for k in range(len(fields))]
    return fields[int(np.argmax(particles))]


def available_memory_bytes() -> float:
    """The memory the machine can give now without swapping (psutil's ``available``)."""
    return float(psutil.virtual_memory().available)


def check_memory(study: Study, processes: int, limit_bytes: float | None = None) -> None:
    """StudyError on the spacing to blame (:func:`spacing_to_blame`) when ``processes`` simulations of
    ``study`` would need more than ``limit_bytes`` (default :func:`available_memory_bytes`)."""
    limit = available_memory_bytes() if limit_bytes is None else float(limit_bytes)
    n = estimated_particles(study)
    need = n * BYTES_PER_PARTICLE * processes
    if need <= limit:  # False for inf and NaN too
        return
    size = (f"about {n:.2g} particles, which need about {need / GIB:.3g} GiB" if math.isfinite(need)
            else "more particles than can be counted")
    where = "this machine has available" if limit_bytes is None else "allowed by --max-memory"
    field, spacing_m = spacing_to_blame(study)
    raise StudyError(
        field,
        f"{spacing_m:g} m gives {size} ({BYTES_PER_PARTICLE / 1000:.1f} kB per particle in each of "
        f"{processes} processes), more than the {limit / GIB:.3g} GiB {where}; use a larger spacing "
        "(or --max-memory GIB to change the limit)",
    )
