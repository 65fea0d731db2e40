"""Runout after failure: the at-rest rule, the runout metrics on a cloud with a known answer, strain
softening that brings down a slope its peak strength holds, the energy budget and mass of a runout,
the animation, and bad softening input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from spfem_core.energy_budget import ENERGY_COLUMNS
from workflows.runout.metrics import runout_summary
from workflows.runout.rest import time_to_rest_s
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
SOFTENING = (REPO / "studies" / "runout_softening.toml").read_text()
REFERENCE = (REPO / "studies" / "runout_reference_slope.toml").read_text()


def _energy(kinetic, released):
    energy = np.zeros((len(kinetic), len(ENERGY_COLUMNS)))
    energy[:, ENERGY_COLUMNS.index("kinetic")] = kinetic
    energy[:, ENERGY_COLUMNS.index("gravity_potential")] = -np.asarray(released)
    return energy


def test_time_to_rest_is_the_start_of_the_last_quiet_window():
    time_s = np.arange(0.0, 3.01, 0.1)
    released = np.full(time_s.size, 1000.0)
    kinetic = np.where(time_s < 1.45, 50.0, 0.5)  # quiet (< 1e-3 x 1000) from t = 1.5 s
    assert time_to_rest_s(time_s, _energy(kinetic, released), 1e-3, 0.5) == pytest.approx(1.5)
    assert np.isnan(time_to_rest_s(time_s[:18], _energy(kinetic[:18], released[:18]), 1e-3, 0.5))  # 1.5-1.7 s
    moving_again = kinetic.copy()
    moving_again[-1] = 50.0
    assert np.isnan(time_to_rest_s(time_s, _energy(moving_again, released), 1e-3, 0.5))


def test_runout_metrics_of_a_known_final_surface():
    """The reference slope (crest x = 20 m at 15 m, toe x = 40 m at 5 m) with the face moved 3 m down and
    out: the surface rises beyond the toe up to x = 46 m and falls behind the crest from x = 17 m."""
    polygon = [[0.0, 0.0], [60.0, 0.0], [60.0, 5.0], [40.0, 5.0], [20.0, 15.0], [0.0, 15.0]]
    h = 0.5
    x = np.arange(0.0, 60.0 + 1e-9, h)
    top = np.interp(x, [0.0, 17.0, 23.0, 43.0, 46.0, 60.0], [15.0, 15.0, 12.0, 6.0, 5.0, 5.0])
    xy = np.column_stack([x, top])
    displacement = np.zeros_like(xy)
    displacement[(x > 17.0) & (x < 46.0), 0] = 3.0
    area = np.full(x.size, 0.25)
    time_s = np.linspace(0.0, 5.0, 11)
    energy = _energy(np.linspace(10.0, 0.0, 11), np.full(11, 1e4))
    summary = runout_summary(polygon, xy, displacement, area, h, time_s, energy, np.linspace(0.0, 2.0, 11),
                             deposit_thickness_m=0.2, moved_threshold_m=0.1, rest_fraction=1e-3, rest_window_s=0.5)
    # raised by more than 0.2 m until y_0 + 0.2 = 5.2 on 43 -> 46 m (y = 6 - (x - 43) / 3): x = 45.4 m
    assert summary["runout_m"] == pytest.approx(5.0, abs=h)
    # lowered by more than 0.2 m from 15 - 0.2 = 14.8 on 17 -> 23 m (y = 15 - (x - 17) / 2): x = 17.4 m
    assert summary["retrogression_m"] == pytest.approx(2.5, abs=h)
    assert summary["sliding_mass_area_m2"] == pytest.approx(0.25 * np.count_nonzero((x > 17.0) & (x < 46.0)))
    assert summary["max_speed_m_s"] == 2.0 and summary["max_speed_time_s"] == 5.0


def _coarse(text: str) -> str:
    return text.replace("spacing_m = 0.5", "spacing_m = 1.0").replace("spacing_m = 0.3", "spacing_m = 1.0")


@pytest.mark.slow
def test_softening_brings_down_a_slope_its_peak_strength_holds(tmp_path):
    """studies/runout_softening.toml at h = 1 m: with softening the slope slides and comes to rest;
    without it the same stage moves a few centimetres (no sliding mass); energy budget within 1% of
    the potential released, mass constant, and the animation written."""
    softening = run_study(parse_study(_coarse(SOFTENING)), tmp_path / "softening")
    peak_only = parse_study(_coarse(SOFTENING).replace('softening = "linear"', 'softening = "none"').replace(
        "residual_cohesion_pa = 2e3\nresidual_friction_deg = 12.0\nsoftening_start_strain = 0.0\n"
        "softening_end_strain = 0.05\n", ""))
    held = run_study(peak_only, tmp_path / "peak_only")
    with xr.open_dataset(softening.paths[1]) as slid, xr.open_dataset(held.paths[1]) as stood:
        assert float(slid["runout_m"]) > 5.0 and float(slid["sliding_mass_area_m2"]) > 50.0
        assert np.isfinite(float(slid["time_to_rest_s"]))
        assert abs(float(slid["energy_budget_error"])) < 0.01
        assert float(stood["sliding_mass_area_m2"]) == 0.0 and float(stood["max_displacement"].max()) < 0.1
        with xr.open_dataset(softening.paths[0]) as gravity:
            assert float(slid["particle_mass"].sum()) == float(gravity["particle_mass"].sum())
    gif = tmp_path / "softening" / "softening.gif"
    assert gif.is_file() and gif.stat().st_size > 10_000


def test_reference_slope_runout_grows_with_the_strength_factor(tmp_path):
    """studies/runout_reference_slope.toml at h = 1 m: more runout, retrogression and sliding mass at
    SRF 3 than at 2, each with the energy budget closed within 1% of the potential released."""
    run = run_study(parse_study(_coarse(REFERENCE).replace("animation_interval_s = 0.1", "animation_interval_s = 1.0")),
                    tmp_path)
    with xr.open_dataset(run.paths[1]) as srf2, xr.open_dataset(run.paths[2]) as srf3:
        for name in ("runout_m", "retrogression_m", "sliding_mass_area_m2", "max_speed_m_s"):
            assert float(srf3[name]) > float(srf2[name]) > 0.0
        for ds in (srf2, srf3):
            assert abs(float(ds["energy_budget_error"])) < 0.01


BAD_SOFTENING = {
    'model = "drucker_prager"\nsoftening = "linear"': "materials[0].softening",
    "residual_friction_deg = 12.0": "materials[0].residual_friction_deg: must be <= friction_deg = 15.6",
    "softening_end_strain = 0.05": "materials[0].softening_end_strain: must be > softening_start_strain",
}


@pytest.mark.parametrize("replacement", sorted(BAD_SOFTENING))
def test_bad_softening_input_names_the_field(replacement):
    text = SOFTENING
    if replacement.startswith("model"):
        text = text.replace('model = "mohr_coulomb"', 'model = "drucker_prager"')
    elif replacement.startswith("residual"):
        text = text.replace(replacement, "residual_friction_deg = 20.0")
    else:
        text = text.replace(replacement, "softening_end_strain = 0.0001").replace(
            "softening_start_strain = 0.0", "softening_start_strain = 0.01")
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert str(error.value).startswith(BAD_SOFTENING[replacement])


def _triggered(trigger: str) -> str:
    """The reference runout study at h = 1 m with one runout stage at full strength and ``trigger``."""
    text = _coarse(REFERENCE).replace("animation_interval_s = 0.1", "animation_interval_s = 1.0")
    head = text.split('[[stages]]\nname = "srf2"')[0]
    return (head + f'[[stages]]\nname = "trig"\nkind = "runout"\nmax_duration_s = 3.0\nrecord_interval_s = 0.01\n'
            f'{trigger}\n[[monitors]]' + text.split("[[monitors]]", 1)[1])


def test_a_seismic_trigger_brings_down_the_slope_its_strength_holds(tmp_path):
    quiet = run_study(parse_study(_triggered("")), tmp_path / "quiet")
    shaken = run_study(parse_study(_triggered("horizontal_coefficient = 0.4\n")), tmp_path / "shaken")
    with xr.open_dataset(quiet.paths[1]) as still, xr.open_dataset(shaken.paths[1]) as slid:
        assert float(still["sliding_mass_area_m2"]) == 0.0
        assert float(slid["sliding_mass_area_m2"]) > 100.0 and float(slid["runout_m"]) > 5.0


def test_a_runout_cut_short_says_its_metrics_are_not_final(tmp_path):
    """A seismic trigger stopped after 0.5 s, mid-slide: the file flags it (final = 0, a warning that
    names max_duration_s) and the command prints it; a slope that stays put is final."""
    moving = _triggered("horizontal_coefficient = 0.4\n").replace("max_duration_s = 3.0", "max_duration_s = 0.5")
    run = run_study(parse_study(moving), tmp_path / "moving")
    with xr.open_dataset(run.paths[1]) as slid:
        assert slid.attrs["final"] == 0 and "still moving at max_duration_s = 0.5 s" in slid.attrs["warning"]
    assert any("still moving" in line for line in run.warnings)
    quiet = run_study(parse_study(_triggered("")), tmp_path / "quiet")
    with xr.open_dataset(quiet.paths[1]) as still:
        assert still.attrs["final"] == 1 and still.attrs["warning"] == ""
    assert quiet.warnings == []


def test_a_water_trigger_sets_the_pore_pressure_of_the_stage(tmp_path):
    """A dry gravity stage, then a runout stage with the water at 8 m inside and outside the slope:
    the stage's pore pressure is gamma_w (8 - y) below 8 m at the final positions, 0 above."""
    run = run_study(parse_study(_triggered("phreatic_level_m = 8.0\npond_level_m = 8.0\n")), tmp_path)
    with xr.open_dataset(run.paths[0]) as gravity, xr.open_dataset(run.paths[1]) as wet:
        assert float(np.abs(gravity["particle_pore_pressure"]).max()) == 0.0
        y = wet["particle_y"].values
        np.testing.assert_allclose(wet["particle_pore_pressure"].values, 9810.0 * np.maximum(8.0 - y, 0.0),
                                   rtol=1e-12, atol=1e-6)
        assert float(wet["energy_load_potential"].values[-1]) != 0.0


@pytest.mark.slow
def test_reference_runout_settles_as_the_spacing_falls(tmp_path):
    """SRF 2 of studies/runout_reference_slope.toml at h = 0.5 and 0.3 m: runout and retrogression
    within 5% of each other (docs/verification.md has four spacings)."""
    text = REFERENCE.replace("animation_interval_s = 0.1", "animation_interval_s = 5.0")
    metrics = []
    for spacing in ("0.5", "0.3"):
        study = parse_study(text.replace("spacing_m = 0.3", f"spacing_m = {spacing}"))
        run = run_study(study, tmp_path / spacing)
        with xr.open_dataset(run.paths[1]) as srf2:
            metrics.append((float(srf2["runout_m"]), float(srf2["retrogression_m"])))
    for coarse, fine in zip(*metrics):
        assert abs(coarse / fine - 1.0) < 0.05
