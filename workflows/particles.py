"""The study's particles: the cloud that fills its polygon, and the material of each.

The particles fill the polygon (``spfem_core.cloud``), uniform at ``geometry.spacing_m`` or graded
around ``[[geometry.refined]]`` zones; each takes the last material whose region holds it.  The
scene (``workflows.scene``), the steady flow (``workflows.seepage.flow``) and the checks of thin
layers (``workflows.layers``) start from the same cloud.
"""

from __future__ import annotations

import functools

import numpy as np

from spfem_core.cloud import graded_particles_in_polygon, particles_in_polygon
from spfem_core.geometry import points_in_polygon
from workflows.fields import StudyError


def material_rows(study, points_xy_m: np.ndarray) -> np.ndarray:
    """Material row of every point: the last material whose region holds it (-1: none)."""
    return rows_of_materials(study.materials, points_xy_m)


def rows_of_materials(materials, points_xy_m: np.ndarray) -> np.ndarray:
    """Row in ``materials`` of every point: the last material whose region holds it (-1: none)."""
    rows = np.full(points_xy_m.shape[0], -1, dtype=np.int64)
    for i, material in enumerate(materials):
        if material.region_m is None:
            rows[:] = i
        else:
            rows[points_in_polygon(points_xy_m, np.array(material.region_m))] = i
    return rows


def assign_materials(study, node_xy_m: np.ndarray) -> np.ndarray:
    """Material row of every particle: the last material whose region holds it."""
    node_material = material_rows(study, node_xy_m)
    orphans = np.flatnonzero(node_material < 0)
    if orphans.size:
        x, y = node_xy_m[orphans[0]]
        raise StudyError(
            "materials",
            f"{orphans.size} particles lie in no material region, e.g. at ({x:g}, {y:g}); "
            "leave region_m out of the first material so that it fills the domain",
        )
    return node_material


def cloud(study) -> tuple[np.ndarray, np.ndarray]:
    """(positions (n, 2), spacing of each particle (n,)) of the study's particle cloud: uniform at
    geometry.spacing_m, or graded around ``[[geometry.refined]]`` zones (``spfem_core.cloud``).
    Made once per geometry in a process (the runs of a study, the realisations of a probabilistic
    one, build the same cloud); each call gets its own copies."""
    return cloud_of_geometry(study.geometry)


def cloud_of_geometry(geometry) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cloud` of a ``[geometry]`` table (copies of the one made per process)."""
    node_xy_m, node_spacing_m = _cloud_of(geometry)
    return node_xy_m.copy(), node_spacing_m.copy()


@functools.lru_cache(maxsize=4)
def _cloud_of(geometry) -> tuple[np.ndarray, np.ndarray]:
    if not geometry.refined:
        node_xy_m = particles_in_polygon(np.array(geometry.polygon_m), geometry.spacing_m, jitter=geometry.jitter,
                                         seed=geometry.seed)
        return node_xy_m, np.full(node_xy_m.shape[0], geometry.spacing_m)
    return graded_particles_in_polygon(np.array(geometry.polygon_m), geometry.spacing_m, geometry.zones,
                                       geometry.grading, jitter=geometry.jitter, seed=geometry.seed)
