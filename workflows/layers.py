"""Thin material layers against the particle spacing: a mechanism through a layer resolved by a
row or two of particles is too strong (the FOS comes out high), so a study names such layers
before it runs.

The thickness of a material's region inside the domain is twice the radius of the largest circle
inside it, measured on the particle cloud: for each particle k of the material,

    r_k = min(d_boundary_k, d_other_k - h_k / 2)

with d_boundary_k its distance to the domain's boundary, d_other_k to the nearest particle of
another material (the interface lies about h_k / 2 before it) and h_k the particle's spacing
(a graded cloud's own); thickness = 2 max_k r_k, against the largest spacing of the material's
particles.  It is within about a spacing of the true thickness: a layer of one row of particles
measures one spacing whether it is 1 cm or nearly two spacings thick, and is named as such.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.geometry import distance_to_edges_m
from workflows.particles import cloud, material_rows

MIN_ROWS = 4
"""A material layer thinner than this many particle spacings is named in a warning."""


def layer_thickness_m(study) -> dict[str, tuple[float, float]]:
    """(thickness, largest particle spacing) of each material's region (module doc), by material
    name; materials that hold no particle or fill the whole domain are left out."""
    polygon = np.array(study.geometry.polygon_m)
    points, spacing = cloud(study)
    rows = material_rows(study, points)
    boundary = distance_to_edges_m(points, polygon)
    thickness = {}
    for i, material in enumerate(study.materials):
        mine = rows == i
        if not mine.any() or mine.all():
            continue
        others = points[~mine & (rows >= 0)]
        to_other = cKDTree(others).query(points[mine])[0] - 0.5 * spacing[mine] if others.size else np.inf
        thickness[material.name] = (2.0 * float(np.max(np.minimum(boundary[mine], to_other))),
                                    float(spacing[mine].max()))
    return thickness


ONE_ROW = 1.5
"""A thickness measured below this many spacings is one row of particles: the layer is thinner than
about two spacings, and the cloud tells no more (a 1 cm layer and a 1.9 h one look alike)."""


def thin_layer_warnings(study) -> list[str]:
    """A warning per plastic material thinner than ``MIN_ROWS`` spacings."""
    plastic = {material.name for material in study.materials if material.plastic}
    warnings = []
    for name, (t, h) in layer_thickness_m(study).items():
        if name not in plastic or t >= MIN_ROWS * h:
            continue
        if t < ONE_ROW * h:
            size = (f"is a layer one row of particles thick at a spacing of {h:g} m (so thinner than about "
                    f"{2.0 * h:.3g} m; the cloud measures it no finer)")
            cure = "a quarter of its thickness"
        else:
            size = f"is a layer about {t:.3g} m thick, {t / h:.2g} particle spacings of {h:g} m"
            cure = f"{t / MIN_ROWS:.3g} m"
        warnings.append(f"warning: material {name!r} {size}: a mechanism through it is resolved by fewer than "
                        f"{MIN_ROWS} rows and the FOS comes out high; make the spacing there at most {cure} "
                        "(geometry.spacing_m, or a [[geometry.refined]] zone)")
    return warnings
