"""Malformed strength-reduction study files: each gives one line naming the field, exit code 2
from the command, and nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from workflows.cli import app
from workflows.scene import build_scene
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()
SR_STAGE = QUICKSTART[QUICKSTART.index('[[stages]]\nname = "srf"'):QUICKSTART.index("[[monitors]]")]
GRAVITY_STAGE = QUICKSTART[QUICKSTART.index('[[stages]]\nname = "gravity"'):QUICKSTART.index('[[stages]]\nname = "srf"')]


def variant(old: str, new: str) -> str:
    assert QUICKSTART.count(old) == 1, old
    return QUICKSTART.replace(old, new)


def shifted(offset_x_m: float) -> str:
    """The quickstart moved by ``offset_x_m`` along x: its polygon, supports and monitors."""
    text = QUICKSTART
    for x in ("60.0", "40.0", "20.0"):
        text = text.replace(f"[{x},", f"[{offset_x_m + float(x)!r},")
    text = text.replace("[0.0, 0.0]", f"[{offset_x_m!r}, 0.0]").replace("[0.0, 15.0]", f"[{offset_x_m!r}, 15.0]")
    text = text.replace("x_max_m = 0.0", f"x_max_m = {offset_x_m!r}")
    text = text.replace("x_min_m = 60.0", f"x_min_m = {offset_x_m + 60.0!r}")
    return text.replace("x_m = 20.0", f"x_m = {offset_x_m + 20.0!r}").replace("x_m = 40.0", f"x_m = {offset_x_m + 40.0!r}")


MALFORMED = {
    "srf_max below srf_min": (variant("srf_max = 2.0", "srf_max = 0.9"), "stages[1].srf_max", "must be >= srf_min = 1"),
    "srf_step wider than the range": (variant("srf_step = 0.1", "srf_step = 1.5"), "stages[1].srf_step", "<= srf_max - srf_min"),
    "srf_step tiny": (variant("srf_step = 0.1", "srf_step = 0.001"), "stages[1].srf_step", "more than 200"),
    "zero srf_min": (variant("srf_min = 1.0", "srf_min = 0.0"), "stages[1].srf_min", "must be >= 0.01"),
    "srf as text": (variant("srf_min = 1.0", 'srf_min = "1.0"'), "stages[1].srf_min", "must be a number"),
    "negative tolerance": (variant("fos_tolerance = 0.01", "fos_tolerance = -0.01"), "stages[1].fos_tolerance", "> 0"),
    "max_runs too small": (variant("fos_tolerance = 0.01", "fos_tolerance = 0.01\nmax_runs = 2"), "stages[1].max_runs", ">= 3"),
    "max_runs not an integer": (variant("fos_tolerance = 0.01", "fos_tolerance = 0.01\nmax_runs = 10.5"), "stages[1].max_runs", "integer"),
    "missing duration": (variant("duration_s = 5.0\n", ""), "stages[1].duration_s", "required field missing"),
    "unknown key in the stage": (variant("fos_tolerance = 0.01", "fos_tolerence = 0.01"), "stages[1].fos_tolerence", "did you mean 'fos_tolerance'"),
    "elastic strength reduction": (variant("srf_step = 0.1", "srf_step = 0.1\nelastic = true"), "stages[1].elastic", "must be false"),
    "continue instead of original positions": (variant("srf_step = 0.1", 'srf_step = 0.1\nstart = "continue"'), "stages[1].start", "original_positions"),
    "rest window longer than half the run": (variant("srf_step = 0.1", 'srf_step = 0.1\nprotocol = "sudden"\nrest_window_s = 3.0'), "stages[1].rest_window_s", "<= duration_s / 2"),
    "rest window for a quasi-static run": (variant("srf_step = 0.1", "srf_step = 0.1\nrest_window_s = 1.0"), "stages[1].rest_window_s", "applies to protocol = ramp or sudden only"),
    "ramp longer than the run": (variant("srf_step = 0.1", 'srf_step = 0.1\nprotocol = "ramp"\nramp_time_s = 6.0'), "stages[1].ramp_time_s", "must be < duration_s"),
    "unknown protocol": (variant("srf_step = 0.1", 'srf_step = 0.1\nprotocol = "slow"'), "stages[1].protocol", "must be one of"),
    "floor above failure": (
        variant("srf_step = 0.1", "srf_step = 0.1\nfailure_displacement_m = 0.5\ndisplacement_floor_m = 0.5"),
        "stages[1].displacement_floor_m", "< failure_displacement_m",
    ),
    "negative failure displacement": (variant("srf_step = 0.1", "srf_step = 0.1\nfailure_displacement_m = -1"), "stages[1].failure_displacement_m", "> 0"),
    "rest growth of 1": (variant("srf_step = 0.1", "srf_step = 0.1\nrest_growth = 1.0"), "stages[1].rest_growth", "< 1"),
    "strength reduction not last": (
        QUICKSTART.replace(SR_STAGE, "").replace(GRAVITY_STAGE, SR_STAGE + GRAVITY_STAGE), "stages[0].kind", "must be the last stage"
    ),
    "no gravity stage before it": (QUICKSTART.replace(GRAVITY_STAGE, ""), "stages[0].kind", "put a relaxation stage before it"),
    "only elastic materials": (
        variant('model = "drucker_prager"\ndp_fit = "mohr_coulomb_match"', 'model = "elastic"').replace(
            "cohesion_pa = 10e3\nfriction_deg = 20.0\ndilation_deg = 0.0\n", ""),
        "materials", "needs a material with strength",
    ),
    "dilation above friction": (variant("dilation_deg = 0.0", "dilation_deg = 25.0"), "materials[0].dilation_deg", "must be <= friction_deg"),
    "friction of 90 degrees": (variant("friction_deg = 20.0", "friction_deg = 90.0"), "materials[0].friction_deg", "< 90"),
    "no strength at all": (
        variant("cohesion_pa = 10e3", "cohesion_pa = 0.0").replace("friction_deg = 20.0", "friction_deg = 0.0"),
        "materials[0].cohesion_pa", "no strength",
    ),
    "unknown dp fit": (variant('dp_fit = "mohr_coulomb_match"', 'dp_fit = "middle"'), "materials[0].dp_fit", "must be one of"),
    "region outside the domain leaves particles without material": (
        variant('name = "soil"', 'name = "soil"\nregion_m = [[100.0, 0.0], [110.0, 0.0], [110.0, 5.0]]'), "materials",
        "lie in no material region",
    ),
    "floor above the default failure displacement": (
        variant("srf_step = 0.1", "srf_step = 0.1\ndisplacement_floor_m = 1.0"), "stages[1].displacement_floor_m",
        "< failure_displacement_m = 0.05 m, 0.005 H by default",
    ),
    "failure displacement beyond the slope": (
        variant("srf_step = 0.1", "srf_step = 0.1\nfailure_displacement_m = 1e6"), "stages[1].failure_displacement_m",
        "no run could fail",
    ),
    "run shorter than the slope's response time": (
        variant("duration_s = 5.0\n", "duration_s = 0.1\n"), "stages[1].duration_s", "shorter than the slope's response time",
    ),
    "stage named as a result file": (variant('name = "gravity"', 'name = "summary"'), "stages[0].name", "name of a result file"),
    "stage named as a run file": (variant('name = "gravity"', 'name = "srf_1.0000"'), "stages[0].name", "name of a result file"),
    "study name longer than a file name allows": (
        variant('name = "quickstart"', f'name = "{"a" * 300}"'), "study.name", "at most 64 characters, got 300",
    ),
    "material whose region holds no particle": (
        QUICKSTART.replace("[loads]", '[[materials]]\nname = "lens"\nmodel = "elastic"\ndensity_kg_m3 = 2000.0\n'
                           'youngs_modulus_pa = 1e8\npoisson_ratio = 0.3\nregion_m = [[100.0, 0.0], [110.0, 0.0], '
                           '[110.0, 5.0]]\n\n[loads]', 1), "materials[1]", "'lens' holds no particle",
    ),
    "no support at all": (
        QUICKSTART[:QUICKSTART.index("[[boundary]]")] + QUICKSTART[QUICKSTART.index("[solver]"):], "boundary",
        "has no support and no wall",
    ),
    "a stage with no support": (variant("srf_step = 0.1", "srf_step = 0.1\nboundary = []"), "stages[1].boundary",
                                "has no support and no wall"),
    "a stage on the side rollers only": (variant("srf_step = 0.1", 'srf_step = 0.1\nboundary = ["left", "right"]'),
                                         "stages[1].boundary", "free to move vertically"),
    "rollers only on the sides": (variant("vy_m_s = 0.0\n", ""), "boundary", "free to move vertically"),
    "no gravity and no load": (variant("gravity_m_s2 = [0.0, -10.0]", "gravity_m_s2 = [0.0, 0.0]"), "loads.gravity_m_s2",
                               "nothing loads the slope"),
    "soil lighter than water": (
        QUICKSTART.replace("[loads]", "[water]\nphreatic_level_m = 8.0\n\n[loads]", 1).replace(
            "density_kg_m3 = 2000.0", "density_kg_m3 = 2000.0\nsaturated_density_kg_m3 = 500.0", 1),
        "materials[0].saturated_density_kg_m3", "the soil would float",
    ),
    "unknown output option": (QUICKSTART + "\n[output]\nfigure = true\n", "output.figure", "did you mean 'figures'"),
    "collapse metrics on an FOS study": (
        QUICKSTART + '\n[metrics]\nkind = "cohesive_collapse"\nmoved_threshold_m = 0.1\n', "metrics", "do not apply",
    ),
    "coordinates too far from the origin for the spacing": (
        shifted(1e10), "geometry.polygon_m", "double precision resolves only 1.9e-06 m at coordinates of 1e+10 m",
    ),
    "a wall through the soil": (
        variant("[solver]", '[[walls]]\nname = "cut"\nstart_m = [10.0, 20.0]\nend_m = [10.0, -5.0]\n\n[solver]'),
        "walls[0]", "lie behind 'cut'",
    ),
    "a floor drawn the wrong way under the soil": (
        variant("[solver]", '[[walls]]\nname = "floor"\nstart_m = [70.0, 0.0]\nend_m = [-10.0, 0.0]\n\n[solver]'),
        "walls[0]", "swap start_m and end_m",
    ),
    "every particle held": (variant("y_max_m = 0.0", "y_max_m = 100.0"), "boundary", "nothing is free to deform"),
}


def check_message(text: str) -> str:
    """The one-line error of a study text, from the loader or from building its scene."""
    try:
        build_scene(parse_study(text))
    except StudyError as error:
        return str(error)
    raise AssertionError("the study was accepted")


def test_at_least_fifteen_malformed_fos_studies():
    assert len(MALFORMED) >= 15


@pytest.mark.parametrize("case", MALFORMED, ids=list(MALFORMED))
def test_malformed_fos_study_names_the_field(case):
    text, field, fragment = MALFORMED[case]
    message = check_message(text)
    assert message.startswith(field + ": ") or message.startswith(field + "["), message
    assert fragment in message, message
    assert "\n" not in message


@pytest.mark.parametrize("case", ["srf_max below srf_min", "region outside the domain leaves particles without material"])
def test_command_exits_2_and_writes_nothing(case, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = tmp_path / "study.toml"
    study.write_text(MALFORMED[case][0])
    result = CliRunner().invoke(app, [str(study), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {study}: {MALFORMED[case][1]}") and result.stderr.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


def test_zero_workers_exits_2(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(QUICKSTART)
    result = CliRunner().invoke(app, [str(study), "--workers", "0", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and result.stderr == "error: --workers: must be in [1, 256], got 0\n"
    assert not (tmp_path / "out").exists()
