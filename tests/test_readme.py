"""The README tells the truth: its study file is valid and runs, its commands exist."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from workflows.scene import build_scene
from workflows.study import parse_study
from workflows.study.reading import sweep_cases

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")


BLOCKS = re.findall(r"```toml\n(.*?)```", README, flags=re.S)
"""The README's TOML: the study file, the sweep axis, the probabilistic tables."""


def test_readme_study_file_is_valid_and_builds_a_scene():
    block = BLOCKS[0]
    study = parse_study(block)
    assert study.strength_reduction is not None
    assert build_scene(study).n_particles > 500
    assert tomllib.loads(block)["study"]["name"] == study.name


def test_readme_sweep_makes_cases_of_the_readme_study():
    block, axis = BLOCKS[:2]
    cases = sweep_cases(parse_study(block + "\n" + axis))
    assert [case.study.materials[0].cohesion_pa for case in cases] == [5e3, 10e3, 15e3]


def test_readme_set_up_commands_are_what_ci_runs():
    ci = (REPO / ".ci" / "run").read_text()
    assert 'pip install -e ".[test]" && python -m pytest -q' in README
    assert 'pip install -e ".[test]"' in ci and "python -m pytest -q" in ci
    assert "pip install -e . && spfem-fos studies/quickstart.toml" in README


def test_readme_links_exist():
    for link in re.findall(r"\]\(([^)#]+)\)", README):
        assert (REPO / link).exists(), link


def test_readme_probabilistic_tables_fit_the_readme_study():
    """[probabilistic] and [random_field] as the README shows them, with the README's study: a
    cohesion field of the given COV at its particles."""
    study = parse_study(BLOCKS[0] + "\n" + BLOCKS[2])
    assert study.probabilistic.realisations == 200 and study.random_field.properties[0].cov == 0.5
    assert "cohesion_pa" in build_scene(study).node_properties
