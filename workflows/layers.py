"""Thin material layers against the particle spacing: a mechanism through a layer resolved by a
row or two of particles is too strong (the FOS comes out high), so a study names such layers
before it runs.

The thickness of a material's region inside the domain is twice the radius of the largest circle
inside it, measured on the particle cloud: for each particle k of the material,

    r_k = min(d_boundary_k, d_other_k - h / 2)

with d_boundary_k its distance to the domain's boundary and d_other_k to the nearest particle of
another material (the interface lies about h / 2 before it); thickness = 2 max_k r_k.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.cloud import particles_in_polygon
from spfem_core.geometry import distance_to_edges_m
from workflows.scene import material_rows

MIN_ROWS = 4
"""A material layer thinner than this many particle spacings is named in a warning."""


def layer_thickness_m(study) -> dict[str, float]:
    """Thickness of each material's region (module doc), by material name; materials that hold no
    particle or fill the whole domain are left out."""
    geometry = study.geometry
    polygon = np.array(geometry.polygon_m)
    h = geometry.spacing_m
    points = particles_in_polygon(polygon, h, jitter=geometry.jitter, seed=geometry.seed)
    rows = material_rows(study, points)
    boundary = distance_to_edges_m(points, polygon)
    thickness = {}
    for i, material in enumerate(study.materials):
        mine = rows == i
        if not mine.any() or mine.all():
            continue
        others = points[~mine & (rows >= 0)]
        to_other = cKDTree(others).query(points[mine])[0] - 0.5 * h if others.size else np.inf
        thickness[material.name] = 2.0 * float(np.max(np.minimum(boundary[mine], to_other)))
    return thickness


def thin_layer_warnings(study) -> list[str]:
    """A warning per plastic material thinner than ``MIN_ROWS`` spacings."""
    h = study.geometry.spacing_m
    plastic = {material.name for material in study.materials if material.plastic}
    return [
        f"warning: material {name!r} is a layer about {t:.3g} m thick, {t / h:.2g} particle spacings of {h:g} m: "
        f"a mechanism through it is resolved by fewer than {MIN_ROWS} rows and the FOS comes out high; make "
        f"geometry.spacing_m at most {t / MIN_ROWS:.3g} m"
        for name, t in layer_thickness_m(study).items() if name in plastic and t < MIN_ROWS * h
    ]
