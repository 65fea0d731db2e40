"""Shared fixtures of the tests: the reference scenes (``verification.scenes``) and one
quickstart study run shared by the FOS, ParaView and notebook tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from verification.scenes import beam_scene, column_scene
from workflows.fos.orchestration import run_fos_study
from workflows.study import load_study

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def make_beam():
    return beam_scene


@pytest.fixture
def make_column():
    return column_scene


@pytest.fixture(scope="session")
def quickstart_run(tmp_path_factory):
    """studies/quickstart.toml run once through a local cluster of 2 worker processes:
    (study, output folder, FosOutcome)."""
    out = tmp_path_factory.mktemp("quickstart")
    study = load_study(REPO / "studies" / "quickstart.toml")
    return study, out, run_fos_study(study, out, workers=2)
