"""Refuse a study the machine cannot hold, before a single particle is made.

The particle count of ``geometry`` is estimated from the polygon: n ~ A / h^2 + P / h (the
lattice inside and the particles on the edges; A the area, P the perimeter, h the spacing).
A process holding a simulation needs about ``BYTES_PER_PARTICLE`` per particle at its peak
(state, mesh, work arrays and Qhull's temporaries during a rebuild: 2.6-3.2 kB of peak resident
memory on the reference slope at 240k and 60k particles, ``python -m
benchmarks.memory_per_particle``), and an FOS
study holds one in its own process and one in each local worker.  A study whose estimate
exceeds the limit (by default the memory the machine has available now) is refused with one
line that names ``geometry.spacing_m``.
"""

from __future__ import annotations

import math

import numpy as np
import psutil

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
    from spfem_core.cloud import spacing_field  # numpy only
    from spfem_core.geometry import ray_casting_inside

    geometry = study.geometry
    polygon = np.array(geometry.polygon_m)
    h0, finest = geometry.spacing_m, geometry.finest_spacing_m
    if not finest > 0.0 or not np.isfinite((np.ptp(polygon, axis=0) / finest).prod()):
        return math.inf
    step = min(h0, np.ptp(polygon, axis=0).min() / 20.0)
    x = np.arange(polygon[:, 0].min() + 0.5 * step, polygon[:, 0].max(), step)
    y = np.arange(polygon[:, 1].min() + 0.5 * step, polygon[:, 1].max(), step)
    grid = np.column_stack([a.ravel() for a in np.meshgrid(x, y)])
    inside = grid[ray_casting_inside(grid, polygon)]
    field = spacing_field(inside, h0, geometry.zones, geometry.grading)
    perimeter = float(np.hypot(*np.diff(np.vstack([polygon, polygon[:1]]), axis=0).T).sum())
    return float(np.sum(step * step / field**2)) + perimeter / finest


def available_memory_bytes() -> float:
    """The memory the machine can give now without swapping (psutil's ``available``)."""
    return float(psutil.virtual_memory().available)


def check_memory(study: Study, processes: int, limit_bytes: float | None = None) -> None:
    """StudyError on ``geometry.spacing_m`` when ``processes`` simulations of ``study`` would need
    more than ``limit_bytes`` (default :func:`available_memory_bytes`)."""
    limit = available_memory_bytes() if limit_bytes is None else float(limit_bytes)
    n = estimated_particles(study)
    need = n * BYTES_PER_PARTICLE * processes
    if need <= limit:  # False for inf and NaN too
        return
    size = (f"about {n:.2g} particles, which need about {need / GIB:.3g} GiB" if math.isfinite(need)
            else "more particles than can be counted")
    where = "this machine has available" if limit_bytes is None else "allowed by --max-memory"
    raise StudyError(
        "geometry.spacing_m",
        f"{study.geometry.spacing_m:g} m gives {size} ({BYTES_PER_PARTICLE / 1000:.1f} kB per particle in each of "
        f"{processes} processes), more than the {limit / GIB:.3g} GiB {where}; use a larger spacing "
        "(or --max-memory GIB to change the limit)",
    )
