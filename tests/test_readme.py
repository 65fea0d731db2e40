"""The README tells the truth: its study file is valid and runs, its commands exist."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from workflows.scene import build_scene
from workflows.study import parse_study

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")


BLOCKS = re.findall(r"```toml\n(.*?)```", README, flags=re.S)
"""The README's TOML: the minimal study file."""


def test_readme_study_file_is_valid_and_builds_a_scene():
    block = BLOCKS[0]
    study = parse_study(block)
    assert study.strength_reduction is not None
    assert build_scene(study).n_particles > 500
    assert tomllib.loads(block)["study"]["name"] == study.name


def test_readme_set_up_commands_are_what_ci_runs():
    ci = (REPO / ".ci" / "run").read_text()
    assert 'pip install -e ".[test]" && python -m pytest -q' in README
    assert 'pip install -e ".[test]"' in ci and "python -m pytest -q" in ci
    assert "python -m ruff check . && python -m mypy" in README
    assert "python -m ruff check ." in ci and "python -m mypy" in ci
    assert "pip install -e . && spfem-fos studies/quickstart.toml" in README


def test_readme_links_exist():
    for link in re.findall(r"\]\(([^)#]+)\)", README):
        assert (REPO / link).exists(), link
