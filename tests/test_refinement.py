"""The refinement study: Richardson extrapolation and the GCI against exact sequences, the
``[refinement]`` table's checks, and a three-level study of the quickstart end to end."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import xarray as xr

from workflows.cases import RunOptions
from workflows.refinement.convergence import (
    CONVERGED,
    EXTRAPOLATED,
    ORDER_OUT_OF_RANGE,
    OSCILLATING,
    extrapolate,
    observed_order,
)
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()


@pytest.mark.parametrize("order", [1.0, 1.5, 2.0])
@pytest.mark.parametrize("spacings", [(1.0, 0.7071, 0.5), (1.0, 0.6, 0.45)])
def test_an_exact_power_law_gives_its_limit_and_its_order(order, spacings):
    """f(h) = 1.35 + 0.04 h^p: the order and the limit come back exactly, also for a varying ratio,
    and the GCI band (Fs = 1.25) holds the limit."""
    fos = [1.35 + 0.04 * h**order for h in spacings]
    x = extrapolate(spacings, fos, resolution=1e-6)
    assert x.status == EXTRAPOLATED
    assert x.observed_order == pytest.approx(order, abs=1e-8)
    assert x.fos == pytest.approx(1.35, abs=1e-10)
    assert x.band_low < 1.35 < x.band_high
    finest = fos[-1]
    r = spacings[1] / spacings[2]
    assert x.band_high - finest == pytest.approx(1.25 * abs(fos[1] - finest) / (r**order - 1.0))


def test_constant_ratio_order_is_the_log_of_the_ratio_of_differences():
    assert observed_order(2.0, 2.0, 0.01, 0.04) == pytest.approx(2.0)


def test_levels_that_do_not_extrapolate_are_said_plainly_with_a_conservative_band():
    oscillating = extrapolate([1.0, 0.7, 0.5], [1.38, 1.36, 1.37], resolution=0.001)
    assert oscillating.status == OSCILLATING and math.isnan(oscillating.observed_order)
    assert oscillating.band_low < 1.36 and oscillating.band_high > 1.38  # wider than the levels' spread
    steep = extrapolate([1.0, 0.7071, 0.5], [1.3701, 1.37, 1.30], resolution=0.0001)  # p << 0.5
    assert steep.status == ORDER_OUT_OF_RANGE
    flat = extrapolate([1.0, 0.7071, 0.5], [1.371, 1.3705, 1.3708], resolution=0.001)
    assert flat.status == CONVERGED and flat.band_low <= 1.3705 and flat.band_high >= 1.371


@pytest.mark.parametrize("block, field, message", [
    ("spacings_m = [1.0, 1.0, 0.5]", "refinement.spacings_m[1]", "at least 5% below"),
    ("spacings_m = [1.0, 0.5]", "refinement.spacings_m", "3 to 6"),
    ("spacings_m = [1.0, 0.7, 0.5]\nlevels = 3", "refinement.spacings_m", "not both"),
    ("ratio = 3.0", "refinement.ratio", "<= 2"),
    ("fos_tolerance = 0.05", "refinement.fos_tolerance", "<= 0.02"),
    ("adaptive_spacing_m = 0.5\nlevels = 3", "refinement.levels", "not both"),
    ("band_margin_m = 1.0", "refinement.band_margin_m", "adaptive_spacing_m only"),
])
def test_bad_refinement_tables_name_the_field(block, field, message):
    with pytest.raises(StudyError) as error:
        parse_study(QUICKSTART + f"\n[refinement]\n{block}\n")
    assert error.value.field == field and message in str(error.value)


def test_a_sweep_refines_every_case_and_each_case_is_the_refinement_study_it_would_be_alone(tmp_path):
    """Two cohesions at h = 2, 1.414, 1 m: study.nc holds each case's finest level and its
    extrapolation; each case's own text, run alone in its folder, reuses every run and finds the
    same levels; a second invocation of the sweep computes nothing."""
    text = QUICKSTART + ("\n[refinement]\nspacings_m = [2.0, 1.4142, 1.0]\n\n[sweep]\n[[sweep.axes]]\n"
                         'path = "materials.soil.cohesion_pa"\nvalues = [10e3, 14e3]\n')
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    ds = xr.load_dataset(tmp_path / "study.nc")
    assert ds.sizes["cohesion_pa"] == 2 and list(ds["finest_spacing"].values) == [1.0, 1.0]
    assert ds["fos"].values[1] > ds["fos"].values[0]  # stronger soil, higher FOS
    for case in outcome.cases:
        folder = tmp_path / "cases" / case.case_id
        alone = run_study(parse_study((folder / "case.toml").read_text()), folder, RunOptions(workers=2))
        assert sum(level.n_runs_made for level in alone.levels) == 0
        assert [level.fos for level in alone.levels] == [level.fos for level in outcome.refinements[case.case_id].levels]
        at = ds.sel(cohesion_pa=case.values["cohesion_pa"])
        assert float(at["fos"]) == alone.levels[-1].fos
        x = alone.extrapolation
        assert (x is None and math.isnan(float(at["fos_extrapolated"]))) or float(at["fos_extrapolated"]) == x.fos
    again = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert again.timings_s["srf_runs_worker"] == 0.0
    for case in outcome.cases:
        assert ([level.fos for level in again.refinements[case.case_id].levels]
                == [level.fos for level in outcome.refinements[case.case_id].levels])


def test_three_levels_of_the_quickstart_extrapolate_and_later_levels_search_near_the_fos(tmp_path):
    """h = 2, 1.414, 1 m: every level has an FOS within the levels' tolerance of its own bracket,
    later levels make fewer runs than the first, refinement.nc holds the levels and the band, and a
    second invocation reuses every run."""
    text = QUICKSTART + "\n[refinement]\nspacings_m = [2.0, 1.4142, 1.0]\n"
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert len(outcome.levels) == 3 and all(math.isfinite(level.fos) for level in outcome.levels)
    assert all(level.fos_high - level.fos_low <= 0.002 + 1e-9 for level in outcome.levels)
    assert all(level.n_runs < outcome.levels[0].n_runs for level in outcome.levels[1:])
    x = outcome.extrapolation
    assert x is not None and x.band_low <= outcome.levels[-1].fos <= x.band_high
    assert outcome.verdict.startswith("FOS = ")
    ds = xr.load_dataset(tmp_path / "refinement.nc")
    assert ds.sizes["level"] == 3 and list(ds["spacing"].values) == [2.0, 1.4142, 1.0]
    assert ds.attrs["verdict"] == outcome.verdict
    assert (tmp_path / "convergence.png").is_file()
    again = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert [level.fos for level in again.levels] == [level.fos for level in outcome.levels]
    assert sum(level.n_runs_made for level in again.levels) == 0  # nothing computed again


class _Progress:
    def __init__(self):
        self.lines = []

    def message(self, text):
        self.lines.append(text)


def _level_outcome(srf_status: list[tuple[float, str]]):
    """A level outcome with no FOS: its runs and the lowest failed SRF (NaN if none failed)."""
    from types import SimpleNamespace

    runs = [SimpleNamespace(srf=srf, status=status) for srf, status in srf_status]
    failed = [srf for srf, status in srf_status if status == "failed"]
    return SimpleNamespace(fos=math.nan, runs=runs, status_high=min(failed) if failed else math.nan,
                           verdict="no FOS")


def test_a_level_whose_fos_lies_at_the_edge_of_its_window_grows_the_window_instead_of_shifting_it(tmp_path):
    """One stable run below the first failure sends the window down, and every run stable sends it
    up: each time it grows by its width, so that it keeps the SRFs it had."""
    from workflows.refinement.study_type import RefinementStudy

    study = RefinementStudy(parse_study(QUICKSTART + "\n[refinement]\nspacings_m = [2.0, 1.4142, 1.0]\n"), tmp_path)
    study.found[0] = 1.40
    study.current = 1
    study.level_studies[1] = study._level_study(1, 1.4142, (1.40, 1.45, 0.01))
    progress = _Progress()
    edge = _level_outcome([(1.40, "stable"), (1.41, "failed")])
    [case] = study.next_cases({study._case_id(1): edge}, progress)
    stage = study.level_studies[1].strength_reduction
    assert (stage.srf_min, stage.srf_max) == (1.35, 1.45)
    # it still holds 1.40-1.41, where the FOS lies (shifted to [1.35, 1.40], every run there is
    # stable and the window went back up to [1.40, 1.45], and so on until the level gave up)
    all_stable = _level_outcome([(1.35, "stable"), (1.40, "stable")])
    study.level_studies[1] = study._level_study(1, 1.4142, (1.35, 1.40, 0.01))
    [case] = study.next_cases({study._case_id(1): all_stable}, progress)
    stage = study.level_studies[1].strength_reduction
    assert (stage.srf_min, stage.srf_max) == (1.35, 1.45)
