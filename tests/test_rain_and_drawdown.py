"""Rain and drawdown in a study (``[transient]``): the table's refusals, the water at a time the
particles carry (with its suction), the rain's history, and the FOS against time."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from spfem_core.soil_water import VanGenuchten
from workflows.cli import app, check_app
from workflows.fos_time.results import bracket, time_fos_reaches
from workflows.scene import build_scene, water_flow
from workflows.study import StudyError, parse_study
from workflows.transient.flow import rain_history, transient_flow
from workflows.transient.table import MM_H_TO_M_S

REPO = Path(__file__).resolve().parents[1]
RAIN = (REPO / "studies" / "rain.toml").read_text()
SMALL = RAIN.replace("spacing_m = 1.0", "spacing_m = 2.0")
"""The shipped rain study at a 2 m spacing (a few hundred particles)."""


def _replace(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


@pytest.mark.parametrize("old, new, field", [
    ("n = 2.0\n", "", "transient.curves[0].n"),
    ('model = "van_genuchten"\n', 'model = "gardner"\n', "transient.curves[0].n"),
    ("residual_water_content = 0.05", "residual_water_content = 0.5", "transient.curves[0].residual_water_content"),
    ('material = "silty_sand"\n', 'material = "clay"\n', "transient.curves"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]\n", "", "transient.boundary[0].rain_mm_h"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]\n",
     "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0]]\nrain_mm_h = 5.0\n", "transient.boundary[0].rain_history_h_mm_h"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
     "rain_history_h_mm_h = [[0.0, 10.0], [12.0, -5.0]]", "transient.boundary[0].rain_history_h_mm_h"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
     "rain_history_h_mm_h = [[0.0, 10.0], [0.0, 5.0]]", "transient.boundary[0].rain_history_h_mm_h"),
    ("total_head_m = 3.0\n", "total_head_m = 3.0\nrain_mm_h = 1.0\n", "transient.boundary[1].rain_mm_h"),
    ("total_head_m = 3.0\n", "total_head_m = 3.0\nloading_efficiency = 0.5\n",
     "transient.boundary[1].loading_efficiency"),
    ('condition = "total_head"\n', 'condition = "reservoir"\n', "transient.boundary[1].total_head_m"),
    ("initial_water_table_m = 3.0\n", "", "transient.initial_water_table_m"),
    ("fos_interval_h = 6.0\n", "fos_interval_h = 60.0\n", "transient.fos_interval_h"),
    ("fos_interval_h = 6.0\n", "fos_interval_h = 6.0\nwater_at_h = 2.0\n", "transient.fos_interval_h"),
    ("fos_interval_h = 6.0\n", "fos_interval_h = 6.0\nfos_times_h = [1.0, 2.0]\n", "transient.fos_interval_h"),
    ("fos_interval_h = 6.0\n", "fos_times_h = [2.0, 1.0]\n", "transient.fos_times_h"),
    ("fos_interval_h = 6.0\nstop_below_fos = 1.0\nrunout_duration_s = 5.0\n", "", "transient.water_at_h"),
    ("fos_interval_h = 6.0\nstop_below_fos = 1.0\nrunout_duration_s = 5.0\n", "water_at_h = 2.0\nstop_below_fos = 1.0\n",
     "transient.stop_below_fos"),
    ("permeability_m_s = 1e-5\n", "", "materials[0].permeability_m_s"),
    ("[transient]\n", "[water]\nphreatic_level_m = 3.0\n\n[transient]\n", "water.phreatic_level_m"),
    ('initial_water_table_m = 3.0\n', 'initial_water_table_m = 3.0\ninitial_state = "steady"\n',
     "transient.initial_water_table_m"),
    ("end_time_h = 48.0\n", "end_time_h = 48.0\nmax_step_h = 100.0\n", "transient.max_step_h"),
    ("stop_below_fos = 1.0\n", "", "transient.runout_duration_s"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]", "evaporation_mm_h = -1.0",
     "transient.boundary[0].evaporation_mm_h"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
     "evaporation_mm_h = 1.0\nsurface_min_head_m = 0.5", "transient.boundary[0].surface_min_head_m"),
    ("rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
     "rain_mm_h = 1.0\nsurface_min_head_m = -10.0", "transient.boundary[0].surface_min_head_m"),
    ("total_head_m = 3.0\n", "total_head_m = 3.0\nevaporation_mm_h = 1.0\n", "transient.boundary[1].evaporation_mm_h"),
])
def test_bad_transient_input_names_its_field(old, new, field):
    """Each refusal names the field, as every table of the study file does."""
    text = _replace(SMALL, old, new)
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == field


def test_bad_transient_input_exits_2_with_one_line_and_check_refuses_it_too(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(_replace(SMALL, "n = 2.0\n", "n = 0.5\n"))
    for command, args in ((app, [str(study), "--out", str(tmp_path / "out")]),
                          (check_app, [str(study), "--out", str(tmp_path / "c")])):
        result = CliRunner().invoke(command, args)
        assert result.exit_code == 2
        assert result.stderr == f"error: {study}: transient.curves[0].n: must be > 1, got 0.5\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


def test_a_dry_limit_above_the_initial_suction_exits_2_with_one_line(tmp_path):
    """The surface starts at -5 m (suction_limit_m): a dry limit of -2 m would wet it; refused naming the field."""
    study = tmp_path / "study.toml"
    study.write_text(_replace(SMALL, "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
                              "evaporation_mm_h = 1.0\nsurface_min_head_m = -2.0"))
    result = CliRunner().invoke(app, [str(study), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.stderr == (f"error: {study}: transient.boundary[0].surface_min_head_m: -2 m is above the initial "
                             "pressure head on the surface of 'rain' (down to -5 m): give a lower limit, or a "
                             "suction_limit_m of at most 2 m\n")
    # rain always more than the evaporation: the surface never evaporates, its dry limit never holds
    wet = _replace(SMALL, "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
                   "rain_mm_h = 10.0\nevaporation_mm_h = 1.0\nsurface_min_head_m = -2.0")
    assert transient_flow(parse_study(wet), until_h=1.0).solution.balance_fraction().max() < 1e-6


def test_evaporation_is_taken_from_the_rain_at_every_time_and_dries_the_slope():
    """Rain 10 mm/h for 12 h less 2 mm/h of evaporation: 8 mm/h, then -2 mm/h (up).  Evaporation alone at 1 mm/h
    for 48 h draws water out of the slope through its surface (the balance closed); with a dry limit of -6 m the
    surface that cannot supply it is held there, and gives less than the demand."""
    entry = parse_study(_replace(SMALL, "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
                                 "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 0.0]]\nevaporation_mm_h = 2.0"
                                 )).transient.boundary[0]
    history = rain_history(entry)
    assert history.at(6 * 3600.0) == pytest.approx(8 * MM_H_TO_M_S)
    assert history.at(20 * 3600.0) == pytest.approx(-2 * MM_H_TO_M_S)
    outflow = {}
    for limit in ("", "\nsurface_min_head_m = -6.0"):
        study = parse_study(_replace(SMALL, "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
                                     "evaporation_mm_h = 1.0" + limit))
        flow = transient_flow(study)
        solution = flow.solution
        assert solution.balance_fraction().max() < 1e-6
        rain = solution.boundary_names.index("rain")
        outflow[limit] = -solution.boundary_cumulative_inflow_m2[-1, rain]
        psi = solution.pressure_head_m(flow.node_xy_m)[-1]
        if limit:
            held = solution.node_held[-1] & flow.problem.boundaries[rain].nodes
            assert held.any() and np.all(np.abs(psi[held] + 6.0) < 1e-12) and psi.min() >= -6.0 - 1e-4
    demand_m2 = 1e-3 * 48 * 60.0  # 1 mm/h for 48 h over the 60 m of horizontal length
    assert 0.0 < outflow["\nsurface_min_head_m = -6.0"] < outflow[""] <= demand_m2 * (1 + 1e-9)


def test_a_rain_box_on_no_boundary_edge_is_refused_naming_the_entry():
    text = _replace(SMALL, 'condition = "rain"\ny_min_m = 5.0\n', 'condition = "rain"\ny_min_m = 40.0\n')
    with pytest.raises(StudyError) as error:
        build_scene(parse_study(text.replace("fos_interval_h = 6.0\nstop_below_fos = 1.0\nrunout_duration_s = 5.0\n",
                                             "water_at_h = 1.0\n")))
    assert error.value.field == "transient.boundary[0]"


def test_an_initial_water_table_above_the_ground_where_no_reservoir_holds_it_is_refused():
    """The table at 300 m over a 15 m slope: every surface particle would carry hundreds of metres of water
    that nothing holds (it ran to a FOS on tensile effective stress)."""
    text = _replace(SMALL, "initial_water_table_m = 3.0", "initial_water_table_m = 300.0")
    with pytest.raises(StudyError, match="295 m above the ground surface") as error:
        transient_flow(parse_study(text))
    assert error.value.field == "transient.initial_water_table_m"


def test_a_study_whose_boundary_is_all_no_flow_keeps_its_water():
    """No [[transient.boundary]] at all: the water redistributes inside, none enters or leaves (the flow
    ended in a reshape error reported as a convergence failure)."""
    rain, far = SMALL.index("[[transient.boundary]]"), SMALL.index("[[monitors]]")
    flow = transient_flow(parse_study(SMALL[:rain] + SMALL[far:]))
    assert flow.solution.water_in_m2[-1] == 0.0 and flow.solution.water_out_m2[-1] == 0.0
    assert flow.solution.balance_fraction().max() < 1e-7


def test_a_rain_history_holds_each_intensity_until_the_next_time():
    """[[0, 10], [12, 50], [42, 0]] mm/h: 10 mm/h to 12 h, 50 to 42 h, none after; its volume exact."""
    entry = parse_study(SMALL).transient.boundary[0]
    history = rain_history(entry)
    hour = 3600.0
    assert history.at(6 * hour) == pytest.approx(10 * MM_H_TO_M_S)
    assert history.at(20 * hour) == pytest.approx(50 * MM_H_TO_M_S)
    assert history.at(44 * hour) == 0.0
    fallen_mm = history.mean(0.0, 48 * hour) * 48 * hour * 1e3
    assert fallen_mm == pytest.approx(10 * 12 + 50 * 30)


def test_the_particles_carry_the_suction_stress_of_their_water_and_terzaghis_pressure_below_it():
    """u = S_e gamma_w psi above the water table (the suction stress, < 0), gamma_w psi below; without
    suction_in_strength gamma_w max(psi, 0) as a steady flow's; saturated density where psi >= 0."""
    text = SMALL.replace("fos_interval_h = 6.0\nstop_below_fos = 1.0\nrunout_duration_s = 5.0\n", "water_at_h = 24.0\n")
    study = parse_study(text)
    water = water_flow(study)
    scene = build_scene(study, water)
    psi = water.pressure_head_m
    curve = VanGenuchten(0.05, 0.40, 0.5, 2.0, 1e-4)
    above = psi < 0.0
    assert above.any() and (~above).any()
    expected = 9810.0 * np.where(above, curve.effective_saturation(psi) * psi, psi)
    # S_e is the lumped mean of the node's triangles' material: one material here, the curve's own
    np.testing.assert_allclose(scene.node_pore_pressure_pa, expected, rtol=1e-9, atol=1e-9)
    assert scene.node_pore_pressure_pa[above].max() < 0.0
    np.testing.assert_array_equal(scene.node_properties["density_kg_m3"] == 2000.0, psi >= 0.0)
    dry = build_scene(parse_study(text.replace("water_at_h = 24.0\n", "water_at_h = 24.0\nsuction_in_strength = false\n")))
    np.testing.assert_allclose(dry.node_pore_pressure_pa, 9810.0 * np.maximum(psi, 0.0))


def test_the_flow_of_a_study_closes_its_mass_balance_and_takes_the_rain_it_is_given():
    study = parse_study(SMALL)
    flow = transient_flow(study)
    solution = flow.solution
    assert solution.times_s[-1] == 48 * 3600.0
    assert solution.balance_fraction().max() < 1e-6
    assert solution.water_in_m2[-1] > 0.0 and solution.stored_water_m2[-1] > solution.stored_water_m2[0]
    # no more rain enters than falls on the 60 m of horizontal length
    fallen_m2 = (10 * 12 + 50 * 30) * 1e-3 * 60.0
    rain_in = solution.boundary_cumulative_inflow_m2[-1, solution.boundary_names.index("rain")]
    assert 0.0 < rain_in <= fallen_m2 * (1 + 1e-9)


def test_water_at_a_time_needs_the_flow_only_as_far_as_that_time():
    study = parse_study(SMALL)
    early = transient_flow(study, until_h=6.0)
    assert early.solution.times_s[-1] == 6 * 3600.0
    np.testing.assert_allclose(early.water_at(6.0).pressure_head_m, transient_flow(study).water_at(6.0).pressure_head_m,
                               atol=1e-9)


def test_the_time_the_fos_reaches_one_is_interpolated_between_the_times_either_side():
    assert time_fos_reaches([0.0, 6.0, 12.0], [1.4, 1.2, 0.8], 1.0) == pytest.approx(9.0)
    assert math.isnan(time_fos_reaches([0.0, 6.0], [1.4, 1.2], 1.0))
    assert time_fos_reaches([0.0, 6.0], [0.9, 0.8], 1.0) == 0.0


@pytest.mark.slow
def test_the_fos_against_time_of_the_shipped_rain_study(tmp_path):
    """The shipped study at a 2 m spacing: the FOS falls with the rain, each time's case carries that
    time's water (its gravity file's pore pressures are the flow's), the searches after the first start
    in a window, and transient.nc closes its balance."""
    from workflows.cases import RunOptions
    from workflows.study_types import run_study

    outcome = run_study(parse_study(SMALL), tmp_path, RunOptions(workers=2))
    fos = [bracket(o)[0] for o in outcome.outcomes.values()]
    assert fos[0] > fos[3]  # the rain lowers it
    assert all(outcome.windows[cid] is not None for cid in list(outcome.outcomes)[1:])
    with xr.open_dataset(tmp_path / "transient.nc") as flow, xr.open_dataset(tmp_path / "fos_time.nc") as curve:
        assert flow.attrs["largest_balance_fraction"] < 1e-6
        np.testing.assert_allclose(curve["fos"].values, fos)
        k = int(np.argmin(np.abs(flow["time"].values - 24.0)))
        with xr.open_dataset(tmp_path / "times" / "t=24h" / "gravity.nc") as gravity:
            np.testing.assert_allclose(gravity["particle_pore_pressure"].values, flow["pore_pressure"].values[k],
                                       rtol=1e-6, atol=1e-6)
    assert (tmp_path / "fos_time.png").is_file()


def test_every_stage_loads_the_surface_with_the_reservoir_at_the_studys_time():
    """The drawdown study's reservoir, 10 m at 0 h to 0 m at 48 h: the pond every stage applies
    (``water.pressure.study_water``, which ``stages.running.stage_setup`` gives each stage) is its level at
    water_at_h, as the flow's held heads are (a stage without it would take the reservoir's support away)."""
    from workflows.water.pressure import study_water

    text = (REPO / "studies" / "drawdown_time.toml").read_text().replace("spacing_m = 0.5", "spacing_m = 2.0")
    for time_h, level_m in ((0.0, 10.0), (24.0, 5.0), (96.0, 0.0)):
        study = parse_study(_replace(text, "fos_times_h = [0.0, 24.0, 36.0, 48.0, 72.0, 96.0, 144.0, 192.0]",
                                     f"water_at_h = {time_h}"))
        scene = build_scene(study)
        assert study_water(study, scene.node_material)[2] == pytest.approx(level_m)
        assert scene.pond_level_m == pytest.approx(level_m)
        water = water_flow(study)
        face = water.node_xy_m[:, 0] > 12.0 + 1e-9
        wet = face & (water.node_xy_m[:, 1] <= level_m) & (water.pressure_head_m > -1e-9)
        assert wet.any() or level_m == 0.0


def test_the_threshold_is_the_duration_at_which_the_fos_falls_to_one_for_each_intensity():
    """A study.nc of FOS over (rain_mm_h, water_at_h) made by hand: 1.5, 1.2, 0.9 at 12, 24, 36 h gives 32 h;
    a row that stays above 1 none; a case without a FOS (every run failed at SRF 0.8) counts as below 1."""
    from workflows.fos_time.threshold import applies, threshold_dataset

    text = (REPO / "studies" / "rain_threshold.toml").read_text()
    study = parse_study(text)
    assert applies(study) and not applies(parse_study(RAIN))
    fos = np.array([[1.5, 1.2, 0.9, 0.8], [1.6, 1.5, 1.4, 1.3], [1.1, np.nan, 0.7, 0.6]])
    high = np.where(np.isnan(fos), 0.8, fos + 0.01)
    dims = ("rain_mm_h", "water_at_h")
    sweep = xr.Dataset({"fos": (dims, fos), "fos_high": (dims, high)},
                       coords={"rain_mm_h": [15.0, 25.0, 40.0], "water_at_h": [12.0, 24.0, 36.0, 48.0]})
    ds = threshold_dataset(study, sweep)
    np.testing.assert_allclose(ds["duration_to_fos_1"].values[[0, 2]], [12 + 12 * (1.2 - 1.0) / 0.3 + 12,
                                                                         12 + 12 * 0.1 / 0.3])
    assert math.isnan(ds["duration_to_fos_1"].values[1])
    np.testing.assert_allclose(ds["lowest_fos"].values, [0.8, 1.3, 0.6])


@pytest.mark.slow
def test_the_slope_that_fails_is_followed_after_failure_at_the_water_of_that_time(tmp_path):
    """The shipped rain study at 2 m, searched at 30 and 42 h (below 1 at 42 h; runout_duration_s 5 s): the
    runout stage runs from the gravity state of 42 h at the slope's own strength, carrying that time's
    pore pressures, and moves."""
    from workflows.cases import RunOptions
    from workflows.study_types import run_study

    text = _replace(SMALL, "fos_interval_h = 6.0\n", "fos_times_h = [30.0, 42.0]\n")
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert outcome.runout is not None and outcome.times_h == [30.0, 42.0]
    with xr.open_dataset(tmp_path / "runout" / "runout.nc") as runout, \
            xr.open_dataset(tmp_path / "times" / "t=42h" / "gravity.nc") as gravity:
        assert float(runout["sliding_mass_area_m2"]) > 0.0
        np.testing.assert_allclose(runout["particle_pore_pressure"].values.min(),
                                   gravity["particle_pore_pressure"].values.min(), rtol=1e-6)


def test_report_html_captions_the_fos_against_time_as_such_and_shows_the_transient_table(tmp_path):
    """fos_time.png is not a sweep's design chart (fos_*.png), and [transient] is among the input tables."""
    from workflows.html_report import _input_tables, _result_figures
    from workflows.output.figures import pyplot, save_figure

    plt = pyplot()
    for name in ("fos_time.png", "threshold.png"):
        fig, _ = plt.subplots()
        save_figure(fig, tmp_path / name)
        plt.close(fig)
    captions = dict((path.name, caption) for path, caption in _result_figures(tmp_path))
    assert captions["fos_time.png"].startswith("The factor of safety against time")
    assert captions["threshold.png"].startswith("The threshold")
    assert "<h3>Transient water</h3>" in _input_tables(parse_study(SMALL))


def test_a_rain_history_and_a_reservoir_level_may_come_from_csv_files_beside_the_study(tmp_path):
    """(time, intensity) and (time, level) files: read in when the study is loaded, written out in its text;
    a file that is not there names the field."""
    from workflows.study import load_study

    (tmp_path / "storm.csv").write_text("t_h,mm_h\n0,10\n12,50\n42,0\n")
    text = _replace(SMALL, "rain_history_h_mm_h = [[0.0, 10.0], [12.0, 50.0], [42.0, 0.0]]",
                    'rain_history_h_mm_h = "storm.csv"')
    (tmp_path / "study.toml").write_text(text)
    study = load_study(tmp_path / "study.toml")
    assert study.transient.boundary[0].rain_history_h_mm_h == ((0.0, 10.0), (12.0, 50.0), (42.0, 0.0))
    assert "storm.csv" not in parse_study(study.source_text).source_text.split("\n", 1)[1]
    (tmp_path / "levels.csv").write_text("0;10\n48;0\n")
    drawdown = (REPO / "studies" / "drawdown_time.toml").read_text()
    (tmp_path / "drawdown.toml").write_text(_replace(drawdown, "level_history_h_m = [[0.0, 10.0], [48.0, 0.0]]",
                                                     'level_history_h_m = "levels.csv"'))
    assert load_study(tmp_path / "drawdown.toml").transient.boundary[0].level_history_h_m == ((0.0, 10.0), (48.0, 0.0))
    (tmp_path / "study.toml").write_text(text.replace("storm.csv", "missing.csv"))
    with pytest.raises(StudyError) as error:
        load_study(tmp_path / "study.toml")
    assert error.value.field == "transient.boundary[0].rain_history_h_mm_h"


def test_a_threshold_chart_of_an_earlier_invocation_is_among_the_sweeps_stale_figures(tmp_path):
    """threshold.png, drawn by an earlier threshold sweep, goes when the sweep does not draw it again
    (figures = false, or no longer a sweep over the time of the water); a user's picture of that name stays."""
    from PIL import Image

    from workflows.output.figures import pyplot, remove_stale_figures, save_figure
    from workflows.sweep.stale import SWEEP_FIGURE_NAMES

    plt = pyplot()
    fig, _ = plt.subplots()
    save_figure(fig, tmp_path / "threshold.png")
    plt.close(fig)
    assert remove_stale_figures(tmp_path, SWEEP_FIGURE_NAMES, keep={"threshold.png"}) == []
    assert remove_stale_figures(tmp_path, SWEEP_FIGURE_NAMES, keep=set()) == ["threshold.png"]
    Image.new("RGB", (20, 20)).save(tmp_path / "threshold.png")
    assert remove_stale_figures(tmp_path, SWEEP_FIGURE_NAMES, keep=set()) == []


def test_a_threshold_of_an_earlier_invocation_goes_when_the_sweep_no_longer_computes_one(tmp_path):
    """threshold.nc, written by an earlier threshold sweep, is removed when a sweep starts in that folder (as its
    study.nc: a stopped sweep must not show one); a sweep that computes no threshold says so in its line, one that
    does writes it again and says nothing; a user's netCDF file of that name stays."""
    import netCDF4

    from workflows.fos_time.threshold import threshold_dataset
    from workflows.output.writing import write_dataset
    from workflows.study_types import study_type

    threshold_text = (REPO / "studies" / "rain_threshold.toml").read_text().replace("spacing_m = 1.0", "spacing_m = 2.0")
    study = parse_study(threshold_text)
    dims = ("rain_mm_h", "water_at_h")
    sweep = xr.Dataset({"fos": (dims, np.full((3, 4), 1.2)), "fos_high": (dims, np.full((3, 4), 1.21))},
                       coords={"rain_mm_h": [15.0, 25.0, 40.0], "water_at_h": [12.0, 24.0, 36.0, 48.0]})
    path = tmp_path / "threshold.nc"
    no_threshold = _replace(threshold_text, "values = [12.0, 24.0, 36.0, 48.0]", "values = [12.0]")
    for text, stale in ((no_threshold, ["threshold.nc"]), (threshold_text, [])):
        write_dataset(threshold_dataset(study, sweep), path)
        kind = study_type(parse_study(text), tmp_path)
        kind.sweep_cases = kind.make_cases()  # what check() sets, without its scenes
        kind.cases()
        assert not path.exists()
        kind._remove_stale_outputs([], [path] if not stale else [])
        assert kind.stale_results == stale
        lines = kind.removed
        assert (lines[0].endswith("results not written again (threshold.nc)") if stale else
                not any("threshold.nc" in line for line in lines))
    with netCDF4.Dataset(path, "w") as mine:
        mine.note = "the user's"
    kind = study_type(parse_study(no_threshold), tmp_path)
    kind.sweep_cases = kind.make_cases()
    kind.cases()
    assert path.is_file() and kind.earlier_results == []


def test_the_fos_against_time_figure_of_an_earlier_invocation_goes_when_not_drawn_again(tmp_path):
    """The small rain study at one time with figures, then with figures = false: fos_time.png is removed,
    said in one line (it showed the earlier invocation's FOS)."""
    from workflows.cases import RunOptions
    from workflows.study_types import run_study, study_type

    text = _replace(SMALL, "fos_interval_h = 6.0\n", "fos_times_h = [0.0]\n")
    lines = []
    for variant in (text, text + "\n[output]\nfigures = false\n"):
        kind = study_type(parse_study(variant), tmp_path)
        outcome = run_study(kind.study, tmp_path, RunOptions(workers=1), kind=kind)
        lines.append(kind.report(outcome, False, None).lines[-1])
        if variant == text:
            assert (tmp_path / "fos_time.png").is_file()
    assert lines[1] == "removed what an earlier invocation made: figures not drawn again (fos_time.png)"
    assert not (tmp_path / "fos_time.png").exists() and (tmp_path / "fos_time.nc").is_file()


def test_check_says_its_limit_equilibrium_circle_of_a_transient_study_is_dry(tmp_path):
    """spfem-fos check draws its circle without the flow (it is not solved for the estimate): its line says so
    rather than passing a dry estimate off as the slope's with its water."""
    study = tmp_path / "study.toml"
    study.write_text(SMALL)
    result = CliRunner().invoke(check_app, [str(study), "--out", str(tmp_path / "c")])
    assert result.exit_code == 0, result.output
    [line] = [line for line in result.stdout.splitlines() if line.startswith("limit equilibrium")]
    assert "dry (the flow of [transient] and its suction are not solved for this estimate)" in line


def test_the_rapid_drawdown_line_is_the_full_reservoirs_pore_pressure_less_the_water_removed():
    """B-bar = 1: under the uncovered face u = gamma_w (y_s - y) (zero on it), under the water left
    gamma_w (L - y), under the crest the full reservoir's gamma_w (H - y); nowhere above the ground unponded."""
    from verification.rain_and_drawdown import _rapid, rapid_line
    from workflows.water.table import water_above_ground_warnings

    polygon = ((0.0, 0.0), (32.0, 0.0), (12.0, 10.0), (0.0, 10.0))  # studies/drawdown.toml's slope
    for level_m in (10.0, 7.5, 5.0, 0.0):
        line = np.array(rapid_line(polygon, 10.0, level_m))
        x = np.linspace(0.0, 32.0, 129)
        ground_m = np.where(x <= 12.0, 10.0, 10.0 - (x - 12.0) / 2.0)
        full_m, removed_m = 10.0, np.maximum(10.0 - np.maximum(ground_m, level_m), 0.0)  # water depth taken away
        np.testing.assert_allclose(np.interp(x, line[:, 0], line[:, 1]), full_m - removed_m, atol=1e-12)
        assert water_above_ground_warnings(_rapid(level_m)) == []


@pytest.mark.slow
def test_the_rapid_drawdown_limit_lies_on_bishops_least_circle_for_the_same_water(tmp_path):
    """Fully drawn down (L / H = 1, no water left on the face): the strength reduction with the rapid line
    within 3% of Bishop's least circle on the same pore pressures (0.871 and 0.857 measured at h = 0.5 m)."""
    from verification.rain_and_drawdown import _rapid
    from workflows.cases import RunOptions
    from workflows.fos.critical_circle import critical_circle
    from workflows.study_types import run_study

    study = _rapid(0.0)
    outcome = run_study(study, tmp_path, RunOptions(workers=2))
    assert outcome.fos == pytest.approx(critical_circle(study).fos, rel=0.03)


@pytest.mark.parametrize("ratio", [0.0, 0.1, 0.5, 0.9])
def test_steady_rain_gives_lu_and_griffiths_suction_under_the_crest(ratio):
    """The rain slope in Gardner's soil over a water table at its base, steady rain q = ratio K_s (h = 1 m): under
    the crest, where the flow is vertical, the particles' pressure head within 0.05 m of Lu & Griffiths' (2004)
    closed form (0.033 m measured at 0.01 K_s; no warning on the way) and their suction stress exp(alpha psi) gamma_w psi within 0.15 kPa
    (0.077 kPa at 0.5 K_s)."""
    from verification.rain_and_drawdown import (
        SUCTION_COLUMN_X_M,
        SUCTION_END_H,
        _suction_study,
        lu_griffiths_pressure_head_m,
        study_permeability_mm_h,
    )

    study = _suction_study(ratio * study_permeability_mm_h())
    water = transient_flow(study).water_at(SUCTION_END_H)
    x, y = water.node_xy_m[:, 0], water.node_xy_m[:, 1]
    column = x <= SUCTION_COLUMN_X_M + 1e-9
    exact = lu_griffiths_pressure_head_m(y[column], ratio, 0.5)
    np.testing.assert_allclose(water.pressure_head_m[column], exact, atol=0.05)
    stress_exact_pa = 9810.0 * np.exp(0.5 * exact) * exact
    np.testing.assert_allclose(water.pore_pressure_pa()[column], stress_exact_pa, atol=150.0)
