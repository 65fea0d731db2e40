"""Mutated study files never end in a traceback, a half-written result or silent nonsense
(``verification.fuzz_study_files``): exit 0 with complete files, exit 2 with one line and nothing
written, or exit 1 with one line when a valid study drives the solver past its limits; and the
oracle's checks of what a run wrote (a mechanism at a supported side without "the box decides",
heads above the ground, a slip line off the domain) each catch what they are for.

A fixed set of 75 mutants of every base (derandomized) keeps the default run bounded (about 60 s
on two idle cores); 300 of the new features' bases (and the slope's and the section's) are ``slow``,
as is a run of every base unmutated; ``python -m verification.fuzz_study_files --examples 300
--random`` explores new ones."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from verification.fuzz_study_files import (
    BASES,
    NEW_FEATURES,
    SEEPAGE,
    SLOPE,
    StudyFiles,
    base_line_files,
    fuzz,
    run_command,
    silent_nonsense,
)
from workflows.study import parse_study


def test_mutated_study_files_end_cleanly():
    counts = fuzz(max_examples=75)
    assert sum(counts[f"exit {code}"] for code in (0, 1, 2)) == 75
    assert counts["exit 2"] > counts["exit 0"] > 0  # both valid and invalid mutants were tried
    assert counts["checked: slip lines"] > 0  # the oracle read what valid runs wrote


@pytest.mark.slow
def test_more_mutated_study_files_of_the_new_features_end_cleanly():
    counts = fuzz(max_examples=300, bases=NEW_FEATURES + ("slope", "section"))
    assert counts["exit 2"] > counts["exit 0"] > 0
    assert counts["checked: slip lines"] > 0 and counts["checked: seepage files"] > 0
    assert counts["checked: slip envelopes"] > 0


def _summary(path: Path, study_text: str, slip_x, slip_y, box_decides: int) -> None:
    ds = xr.Dataset({"slip_x": ("slip_point", np.asarray(slip_x, float)),
                     "slip_y": ("slip_point", np.asarray(slip_y, float))},
                    attrs={"study": study_text, "box_decides": box_decides, "mechanism_edges": ""})
    path.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path / "summary.nc")


# the slope of SLOPE: ground y = 8 for x <= 10, down to 3 at x = 20, 3 to x = 30; a roller holds x = 0
SCARP_AT_THE_SUPPORTED_SIDE = ([0.5, 5.0, 10.0, 15.0, 21.0], [8.0, 5.0, 3.5, 2.0, 3.0])
TOE_AT_THE_FREE_SIDE = ([5.0, 10.0, 15.0, 25.0, 29.5], [8.0, 4.0, 2.0, 1.0, 3.0])


def test_the_oracle_wants_the_box_to_decide_where_the_line_comes_out_at_a_supported_side(tmp_path):
    _summary(tmp_path / "quiet", SLOPE, *SCARP_AT_THE_SUPPORTED_SIDE, box_decides=0)
    problems = silent_nonsense(tmp_path / "quiet", said="FOS = 1.15")
    assert len(problems) == 1 and "supported side x = 0 m, yet box_decides = 0" in problems[0]
    assert not silent_nonsense(tmp_path / "quiet", said="WARNING, the box decides: the mechanism reaches ...")
    _summary(tmp_path / "said", SLOPE, *SCARP_AT_THE_SUPPORTED_SIDE, box_decides=1)
    assert not silent_nonsense(tmp_path / "said", said="")
    _summary(tmp_path / "free", SLOPE, *TOE_AT_THE_FREE_SIDE, box_decides=0)  # x = 30 is held by nothing
    assert not silent_nonsense(tmp_path / "free", said="")


@pytest.mark.parametrize("x, y, what", [
    ([5.0, 10.0, 15.0, 21.0], [8.0, 4.0, -2.0, 3.0], "outside the domain"),  # below the base
    ([5.0, 10.0, 15.0, 21.0], [8.0, 10.0, 6.0, 3.0], "outside the domain"),  # above the ground
    ([5.0, 10.0, 15.0, 45.0], [8.0, 4.0, 2.0, 3.0], "outside the domain"),  # beyond the side
    ([5.0, 10.0, 15.0, 21.0], [6.0, 4.0, 2.0, 3.0], "entry (5, 6) m is not on the ground"),
])
def test_the_oracle_finds_a_slip_line_that_leaves_the_moving_mass(tmp_path, x, y, what):
    _summary(tmp_path, SLOPE, x, y, box_decides=0)
    problems = silent_nonsense(tmp_path, said="")
    assert len(problems) == 1 and what in problems[0]
    _summary(tmp_path, SLOPE, [5.0, 10.0, 15.0, 21.0], [8.0, 4.0, 2.0, 3.0], box_decides=0)
    assert not silent_nonsense(tmp_path, said="")


def _seepage(path: Path, study_text: str, heads_above_m: float, condition: int) -> None:
    """A seepage.nc of a few particles of the ground and below it, every head at the particle's
    elevation but one ground particle's (x = 5, y = 8), ``heads_above_m`` above it, held by the condition
    ``condition`` (-1: none; the conditions named as the command names them: the pond first)."""
    study = parse_study(study_text)
    x = np.array([0.0, 5.0, 15.0, 25.0, 5.0, 15.0])
    y = np.array([8.0, 8.0, 5.5, 3.0, 6.0, 2.0])
    head = y.copy()
    head[1] += heads_above_m
    conditions = np.full(x.size, -1)
    conditions[1] = condition
    names = ["pond"] * (study.water is not None) + [entry.name for entry in study.seepage.boundary]
    ds = xr.Dataset({"particle_x": ("particle", x), "particle_y": ("particle", y), "total_head": ("particle", head),
                     "particle_condition": ("particle", conditions),
                     "condition": ("condition", np.array(names, dtype=object))}, attrs={"study": study_text})
    path.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path / "seepage.nc")


def test_the_oracle_finds_heads_above_the_ground_that_nothing_holds(tmp_path):
    # SEEPAGE's conditions: rain (infiltration), face (seepage face), left and right (total heads)
    _seepage(tmp_path / "rain", SEEPAGE, 3.0, condition=0)
    problems = silent_nonsense(tmp_path / "rain", said="")
    assert len(problems) == 1 and "stands 3 m above it" in problems[0] and "its condition: rain" in problems[0]
    _seepage(tmp_path / "none", SEEPAGE, 3.0, condition=-1)
    assert len(silent_nonsense(tmp_path / "none", said="")) == 1
    _seepage(tmp_path / "head", SEEPAGE, 3.0, condition=2)  # the total head of 'left' holds it
    assert not silent_nonsense(tmp_path / "head", said="")
    _seepage(tmp_path / "within", SEEPAGE, 0.05, condition=0)  # within a tenth of the spacing
    assert not silent_nonsense(tmp_path / "within", said="")
    ponded = SEEPAGE.replace("[seepage]", "[water]\npond_level_m = 11.0\n\n[seepage]")
    _seepage(tmp_path / "pond", ponded, 3.0, condition=0)  # under the pond
    assert not silent_nonsense(tmp_path / "pond", said="")
    _seepage(tmp_path / "pond_rain", ponded, 3.0, condition=1)  # rain, with a pond elsewhere
    assert len(silent_nonsense(tmp_path / "pond_rain", said="")) == 1


@pytest.mark.slow
@pytest.mark.parametrize("base", sorted(BASES))
def test_every_base_is_a_valid_study_the_oracle_passes(tmp_path, base):
    """Unmutated, each base runs to exit 0 with nothing the oracle objects to (its mutants then are
    the hostile inputs)."""
    outcome = run_command(StudyFiles(BASES[base].encode(), base_line_files() if base == "lines" else {}), tmp_path)
    assert outcome.exit_code == 0 and not outcome.problems, (outcome.stderr, outcome.problems)
