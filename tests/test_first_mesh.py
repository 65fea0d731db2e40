"""The first mesh a worker keeps per cloud (``workflows.fos.task.first_mesh``): cases that differ only in
strength share it, a case with another cloud or alpha does not, and a run made from a kept mesh is the
run made afresh, array for array."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from workflows.fos import task
from workflows.fos.gravity import run_gravity
from workflows.scene import build_scene
from workflows.study import parse_study

QUICKSTART = (Path(__file__).resolve().parents[1] / "studies" / "quickstart.toml").read_text()
COARSE = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 2.0")
"""The quickstart at h = 2 m (196 particles): runs of a tenth of a second."""
WEAKER = COARSE.replace("cohesion_pa = 10e3", "cohesion_pa = 7e3").replace("friction_deg = 20.0", "friction_deg = 17.0")
"""The same slope and cloud, another strength."""


@pytest.fixture
def no_kept_meshes():
    task._first_meshes.clear()
    yield
    task._first_meshes.clear()


def test_a_case_differing_only_in_strength_gets_the_kept_mesh_and_another_cloud_or_alpha_does_not(no_kept_meshes):
    kept = task.first_mesh(build_scene(parse_study(COARSE)))
    assert task.first_mesh(build_scene(parse_study(WEAKER))) is kept
    finer = task.first_mesh(build_scene(parse_study(COARSE.replace("spacing_m = 2.0", "spacing_m = 1.5"))))
    assert finer is not kept and finer.elem_nodes.shape != kept.elem_nodes.shape
    other_alpha = COARSE.replace("[solver]\n", "[solver]\nalpha = 1.6\n", 1)
    assert parse_study(other_alpha).solver.alpha == 1.6
    assert task.first_mesh(build_scene(parse_study(other_alpha))) is not kept
    assert task.first_mesh(build_scene(parse_study(COARSE))) is kept  # still kept (at most FIRST_MESHES_KEPT)


def test_a_run_from_the_mesh_another_case_left_equals_the_run_made_afresh(no_kept_meshes):
    study, weaker = parse_study(COARSE), parse_study(WEAKER)
    gravity = run_gravity(COARSE, threads=1).state
    assert np.array_equal(gravity.stress_pa, run_gravity(WEAKER, threads=1).state.stress_pa)  # one gravity state
    afresh = task.run_srf(weaker, gravity, 1.1)
    task._first_meshes.clear()
    task.run_srf(study, gravity, 1.3)  # leaves its cloud's mesh on this "worker"
    assert len(task._first_meshes) == 1
    kept = task.run_srf(weaker, gravity, 1.1)
    assert len(task._first_meshes) == 1  # it found the mesh
    wall = ("wall_time_s", "remesh_wall_s")
    assert ({k: v for k, v in vars(kept.record).items() if k not in wall}
            == {k: v for k, v in vars(afresh.record).items() if k not in wall})
    a, b = afresh.dataset, kept.dataset
    assert set(a.variables) == set(b.variables) and len(a.variables) > 20
    for name in a.variables:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=a[name].dtype.kind == "f"), name
