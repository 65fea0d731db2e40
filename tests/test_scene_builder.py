"""From a study to the core's Scene: materials by region, supports by box, monitors by nearest particle."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from workflows.scene import build_scene, monitor_particles, solver_settings
from workflows.study import StudyError, load_study, parse_study

REPO = Path(__file__).resolve().parents[1]
BEAM = (REPO / "studies" / "cantilever_beam.toml").read_text().replace("spacing_m = 0.02", "spacing_m = 0.05")
RIGHT_HALF = """
[[materials]]
name = "stiff"
model = "elastic"
density_kg_m3 = 2000.0
youngs_modulus_pa = 160e6
poisson_ratio = 0.3
region_m = [[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]]
"""


def test_beam_scene():
    study = parse_study(BEAM)
    scene = build_scene(study)
    x, y = scene.node_xy_m.T
    assert scene.spacing_m == 0.05 and scene.alpha == 1.5
    np.testing.assert_array_equal(scene.gravity_m_s2, [0.0, -9.8])
    clamped = np.isclose(x, 0.0)
    assert clamped.sum() == 5  # 0.2 m deep at h = 0.05
    assert scene.node_fixed[clamped].all() and not scene.node_fixed[~clamped].any()
    (tip,) = monitor_particles(study, scene)
    np.testing.assert_allclose(scene.node_xy_m[tip], [2.0, 0.2], atol=1e-12)
    settings = solver_settings(study)
    assert settings.cfl == 0.5 and settings.dt_s is None and settings.stabilisation_beta == 0.1


def test_later_material_regions_override_earlier_ones():
    scene = build_scene(parse_study(BEAM.replace("[loads]", RIGHT_HALF + "\n[loads]")))
    x = scene.node_xy_m[:, 0]
    assert scene.materials.name == ("beam", "stiff")
    assert (scene.node_material[x > 1.01] == 1).all() and (scene.node_material[x < 0.99] == 0).all()
    np.testing.assert_array_equal(scene.materials.youngs_modulus_pa, [80e6, 160e6])


def test_particles_outside_every_region_are_refused():
    triangle = "region_m = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.2]]"
    text = BEAM.replace("poisson_ratio = 0.25", f"poisson_ratio = 0.25\n{triangle}")
    with pytest.raises(StudyError, match=r"^materials: \d+ particles lie in no material region"):
        build_scene(parse_study(text))


def test_empty_boundary_box_is_refused():
    with pytest.raises(StudyError, match=r"^boundary\[0\]: the box of 'clamp' holds no particle"):
        build_scene(parse_study(BEAM.replace("x_max_m = 0.0", "x_min_m = 2.5")))


def test_shipped_column_has_rollers_and_a_rough_base():
    scene = build_scene(load_study(REPO / "studies" / "elastic_column.toml"))
    x, y = scene.node_xy_m.T
    base, sides = np.isclose(y, 0.0), np.isclose(x, 0.0) | np.isclose(x, 2.0)
    # the base is rough (held across, sliding along at the soil's strength; an elastic soil cannot slide),
    # its corners held both ways by the rollers too
    assert scene.node_fixed[base, 1].all() and (scene.node_slip_length_m[base & ~sides] > 0.0).all()
    assert scene.node_fixed[base & sides].all() and not scene.node_fixed[base & ~sides, 0].any()
    assert scene.node_fixed[sides, 0].all() and not scene.node_fixed[sides & ~base, 1].any()
    assert not scene.node_fixed[~base & ~sides].any()
