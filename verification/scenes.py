"""Reference scenes built directly on the core (no study file): the cantilever beam and the
elastic column of the method notes (section 4)."""

from __future__ import annotations

import numpy as np

from spfem_core import MaterialTable, Scene
from spfem_core.cloud import particles_in_polygon

BEAM_LENGTH_M = 2.0
BEAM_DEPTH_M = 0.2
BEAM_DENSITY_KG_M3 = 1850.0
BEAM_YOUNGS_MODULUS_PA = 80e6
BEAM_POISSON_RATIO = 0.25
BEAM_GRAVITY_M_S2 = 9.8


def beam_scene(spacing_m: float, jitter: float = 0.0, seed: int = 0, poisson_ratio: float = BEAM_POISSON_RATIO) -> Scene:
    """ESPFEM2D example 1: 2.0 x 0.2 m cantilever, clamped at x = 0, E 80 MPa, nu 0.25, rho 1850, g 9.8."""
    xy = particles_in_polygon(
        [[0.0, 0.0], [BEAM_LENGTH_M, 0.0], [BEAM_LENGTH_M, BEAM_DEPTH_M], [0.0, BEAM_DEPTH_M]],
        spacing_m,
        jitter=jitter,
        seed=seed,
    )
    scene = Scene(
        xy,
        np.zeros(len(xy), dtype=np.int64),
        MaterialTable.elastic("beam", BEAM_DENSITY_KG_M3, BEAM_YOUNGS_MODULUS_PA, poisson_ratio),
        spacing_m,
        gravity_m_s2=[0.0, -BEAM_GRAVITY_M_S2],
    )
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene


def column_scene(spacing_m: float, width_m=2.0, height_m=10.0, density=2000.0, youngs=1e8, nu=0.3, g=10.0,
                 node_xy_m=None) -> Scene:
    """Elastic column: base fixed, sides on rollers (uniaxial strain under gravity); ``node_xy_m``
    replaces the lattice of ``spacing_m`` with a cloud of one's own."""
    xy = particles_in_polygon([[0.0, 0.0], [width_m, 0.0], [width_m, height_m], [0.0, height_m]], spacing_m) \
        if node_xy_m is None else node_xy_m
    scene = Scene(
        xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", density, youngs, nu), spacing_m,
        gravity_m_s2=[0.0, -g],
    )
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0)
    scene.fix(scene.select_box(x_min=width_m), vx_m_s=0.0)
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene
