"""Shared scene factories for the verification tests (core level, no study files)."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core.cloud import particles_in_polygon
from spfem_core.scene import MaterialTable, Scene

BEAM_LENGTH_M = 2.0
BEAM_DEPTH_M = 0.2


def beam_scene(spacing_m: float, jitter: float = 0.0, seed: int = 0) -> Scene:
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
        MaterialTable.elastic("beam", 1850.0, 80e6, 0.25),
        spacing_m,
        gravity_m_s2=[0.0, -9.8],
    )
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene


def column_scene(spacing_m: float, width_m=2.0, height_m=10.0, density=2000.0, youngs=1e8, nu=0.3, g=10.0) -> Scene:
    """Elastic column: base fixed, sides on rollers (uniaxial strain under gravity)."""
    xy = particles_in_polygon([[0.0, 0.0], [width_m, 0.0], [width_m, height_m], [0.0, height_m]], spacing_m)
    scene = Scene(
        xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("soil", density, youngs, nu), spacing_m,
        gravity_m_s2=[0.0, -g],
    )
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0)
    scene.fix(scene.select_box(x_min=width_m), vx_m_s=0.0)
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    return scene


@pytest.fixture
def make_beam():
    return beam_scene


@pytest.fixture
def make_column():
    return column_scene


@pytest.fixture(scope="session")
def quickstart_run(tmp_path_factory):
    """studies/quickstart.toml run once through a local cluster of 2 worker processes:
    (study, output folder, FosOutcome).  Shared by the FOS, ParaView and notebook tests."""
    from pathlib import Path

    from workflows.fos_study import run_fos_study
    from workflows.study import load_study

    out = tmp_path_factory.mktemp("quickstart")
    study = load_study(Path(__file__).resolve().parents[1] / "studies" / "quickstart.toml")
    return study, out, run_fos_study(study, out, workers=2)
