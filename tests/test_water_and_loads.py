"""Water, surface loads, the seismic load and the tension cut-off: hydrostatics against the closed
form, buoyancy, the strip load against Prandtl, the energy budget with loads, the return maps, the
pseudo-static body force, and the bad inputs of [water] and [loads] (exit 2, one line)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.cloud import particles_in_polygon
from spfem_core.energy_budget import ENERGY_COLUMNS
from spfem_core.materials.tension_cutoff import tension_cutoff
from spfem_core.simulation import Simulation
from verification.study_text import box_m, elastic_soil, gravity, gravity_stage, held_base_and_sides, study_text
from verification.water_and_loads import DRAWDOWN_REFERENCE, SEISMIC_KC, prandtl_fos
from workflows.cases import RunOptions
from workflows.cli import app
from workflows.scene import build_scene
from workflows.study import parse_study
from workflows.study_types import run_study
from workflows.water.table import water_above_ground_warnings

REPO = Path(__file__).resolve().parents[1]
GAMMA_W = 9810.0

SATURATED_GROUND = study_text(
    "saturated_ground", {"polygon_m": box_m(10.0, 5.0), "spacing_m": 0.25},
    [elastic_soil(density_kg_m3=1800.0, saturated_density_kg_m3=2000.0, youngs_modulus_pa=20e6)],
    [gravity_stage(20.0, 0.05, tolerance=1e-5), {"name": "hold", "kind": "dynamic", "duration_s": 1.0,
                                                 "record_interval_s": 0.01}],
    loads=gravity(9.81), water={"phreatic_level_m": 5.0}, boundary=held_base_and_sides(0.0, 10.0))


def test_level_saturated_ground_has_the_hydrostatic_effective_stress_and_does_not_move(tmp_path):
    """sigma'_v = (gamma_sat - gamma_w) z to 1% down the middle of the ground, u = gamma_w z, the
    relaxation converges to the study's tolerance, and the gravity state held from the original
    positions (undamped, 1 s) moves less than 1e-6 m."""
    run = run_study(parse_study(SATURATED_GROUND), tmp_path)
    assert run.unconverged_stages == []
    with xr.open_dataset(run.paths[0]) as gravity:
        y0, x0 = gravity["particle_y0"].values, gravity["particle_x0"].values
        depth = 5.0 - y0
        middle = (np.abs(x0 - 5.0) < 0.01) & (depth > 0.0) & (y0 > 0.0)
        effective_exact = -(2000.0 * 9.81 - GAMMA_W) * depth[middle]
        error = np.abs(gravity["particle_syy"].values[middle] - effective_exact).max() / np.abs(effective_exact).max()
        assert error < 0.01
        # a gravity stage balances the pore pressure of the initial positions, where the next stage starts
        np.testing.assert_allclose(gravity["particle_pore_pressure"].values[middle], GAMMA_W * depth[middle],
                                   rtol=1e-12)
    with xr.open_dataset(run.paths[1]) as hold:
        assert float(hold["max_displacement"].max()) < 1e-6


def test_water_changes_nothing_where_the_ground_is_dry(tmp_path):
    """A piezometric line below the base leaves every number of the dry study unchanged."""
    dry = parse_study(SATURATED_GROUND.replace("saturated_density_kg_m3 = 2000.0\n", "").replace(
        "[water]\nphreatic_level_m = 5.0\n", ""))
    wet = parse_study(SATURATED_GROUND.replace("saturated_density_kg_m3 = 2000.0\n", "").replace(
        "phreatic_level_m = 5.0", "phreatic_level_m = -1.0"))
    paths = [run_study(study, tmp_path / name).paths for name, study in (("dry", dry), ("wet", wet))]
    with xr.open_dataset(paths[0][0]) as a, xr.open_dataset(paths[1][0]) as b:
        np.testing.assert_array_equal(a["particle_syy"].values, b["particle_syy"].values)
        assert float(np.abs(b["energy_load_potential"]).max()) == 0.0


def _energy_drift_under_strip_load(cfl: float):
    """A 4 x 2 m weightless elastic block on a fixed base under a suddenly applied strip load, 0.2 s
    undamped: (the budget's change from its start at every record, the largest |load potential|)."""
    xy = particles_in_polygon([[0, 0], [4, 0], [4, 2], [0, 2]], 0.2)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), MaterialTable.elastic("block", 2000.0, 1e7, 0.3), 0.2,
                  gravity_m_s2=[0.0, 0.0])
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    load = np.zeros_like(xy)
    top = scene.select_box(y_min=2.0, x_min=1.0, x_max=3.0)
    load[top, 1] = -50e3 * 2.0 / top.size
    scene.node_load_n = load
    series = Simulation(scene, SolverSettings(cfl=cfl)).run(0.2)
    total = series.energy_j_per_m.sum(axis=1)
    return total - total[0], np.abs(series.energy("load_potential")).max()


def test_energy_budget_closes_with_a_surface_load():
    """The load potential closes the budget: no energy is created on average, and what the budget
    wobbles (the leapfrog's half-step kinetic energy, large under a load on a few particles) halves
    with the time step."""
    coarse, _ = _energy_drift_under_strip_load(0.25)
    fine, scale = _energy_drift_under_strip_load(0.125)
    assert scale > 0.0 and "load_potential" in ENERGY_COLUMNS
    assert abs(fine.mean()) < 0.001 * scale
    assert np.abs(fine).max() < 0.6 * np.abs(coarse).max()
    assert np.abs(fine).max() < 0.02 * scale


@pytest.mark.parametrize("model", ["mohr_coulomb", "drucker_prager"])
def test_tension_cutoff_caps_the_stress_and_a_second_pass_is_a_no_op(model):
    lame, shear = 5.77e6, 3.85e6
    rng = np.random.default_rng(1)
    for _ in range(200):
        stress = rng.normal(0.0, 50e3, size=(1, 4))
        tensile = 5e3
        d_eq, work = tension_cutoff(stress, 0, model == "drucker_prager", tensile, lame, shear)
        sxx, syy, szz, sxy = stress[0]
        if model == "drucker_prager":
            assert (sxx + syy + szz) / 3.0 <= tensile * (1 + 1e-12)
        else:
            major = 0.5 * (sxx + syy) + math.hypot(0.5 * (sxx - syy), sxy)
            assert max(major, szz) <= tensile + 1e-9 * 50e3
        assert d_eq >= 0.0 and work >= -1e-9
        again = stress.copy()
        assert tension_cutoff(again, 0, model == "drucker_prager", tensile, lame, shear) == (0.0, 0.0)
        np.testing.assert_array_equal(again, stress)


def test_seismic_body_force_points_out_of_the_slope():
    """The crest of studies/seismic.toml is on the left: out of the slope is +x; from the first stage
    on by default, in the runs only with in_gravity = false; kv > 0 lightens the soil."""
    text = (REPO / "studies" / "seismic.toml").read_text()
    study = parse_study(text)
    g = 9.81
    kh = study.loads.seismic.horizontal_coefficient
    in_runs = study.loads.acceleration_m_s2(study.geometry.polygon_m, strength_reduction=True)
    np.testing.assert_allclose(in_runs, [kh * g, -g])
    np.testing.assert_allclose(build_scene(study).gravity_m_s2, [kh * g, -g])
    runs_only = parse_study(text.replace('direction = "out_of_slope"', 'direction = "out_of_slope"\nin_gravity = false'))
    np.testing.assert_allclose(build_scene(runs_only).gravity_m_s2, [0.0, -g])
    mirrored = parse_study(text.replace('"out_of_slope"', '"-x"\nvertical_coefficient = 0.1'))
    in_runs = mirrored.loads.acceleration_m_s2(mirrored.geometry.polygon_m, strength_reduction=True)
    np.testing.assert_allclose(in_runs, [-kh * g, -0.9 * g])


def test_strip_load_puts_its_resultant_on_the_surface():
    study = parse_study((REPO / "studies" / "strip_load.toml").read_text())
    scene = build_scene(study)
    strip = study.loads.strip[0]
    loaded = np.flatnonzero(scene.node_load_n[:, 1])
    assert scene.node_load_n.sum(axis=0) == pytest.approx([0.0, -strip.pressure_pa * 2.0])
    assert np.all(scene.node_xy_m[loaded, 1] == 6.0)
    moment = (scene.node_load_n[:, 1] * scene.node_xy_m[:, 0]).sum()
    assert moment == pytest.approx(-strip.pressure_pa * 2.0 * 11.0)


SUBMERGED = """
[water]
unit_weight_n_m3 = 10000.0
phreatic_level_m = 16.0
pond_level_m = 16.0
"""


def test_submerged_slope_has_the_fos_of_the_buoyant_slope(tmp_path):
    """A slope under water (piezometric line = water level above the crest, saturated density) and the
    same slope dry with the buoyant density rho_sat - rho_w (gamma_w = 10 kN/m3 with g = 10 m/s2):
    equal FOS brackets."""
    text = (REPO / "studies" / "quickstart.toml").read_text()
    wet = parse_study(text.replace("[loads]", SUBMERGED + "\n[loads]"))
    rho = wet.materials[0].density_kg_m3
    buoyant = parse_study(text.replace(f"density_kg_m3 = {rho:.1f}", f"density_kg_m3 = {rho - 1000.0:.1f}"))
    assert buoyant.materials[0].density_kg_m3 == pytest.approx(rho - 1000.0)
    dry = parse_study(text)
    fos = [run_study(study, tmp_path / name, RunOptions(workers=2))
           for name, study in (("wet", wet), ("buoyant", buoyant), ("dry", dry))]
    assert (fos[0].fos_low, fos[0].fos_high) == (fos[1].fos_low, fos[1].fos_high)
    assert fos[0].fos > 1.2 * fos[2].fos  # the water matters: buoyancy halves the weight, not c


BAD_INPUTS = {
    "non_increasing_line": (
        "[water]\nphreatic_line_m = [[-1.0, 10.0], [30.0, 8.0], [20.0, 7.0], [70.0, 5.0]]\n",
        "water.phreatic_line_m: x must increase from point to point: point 2 has x = 20 after 30",
    ),
    "line_outside_domain": (
        "[water]\nphreatic_line_m = [[10.0, 10.0], [40.0, 8.0]]\n",
        "water.phreatic_line_m: must span the domain's x-range [0, 60] m; it covers [10, 40]",
    ),
    "negative_unit_weight": (
        "[water]\nunit_weight_n_m3 = -9810.0\nphreatic_level_m = 10.0\n",
        "water.unit_weight_n_m3: must be > 0, got -9810.0",
    ),
    "kh_above_one": (
        "[loads.seismic]\nhorizontal_coefficient = 1.2\n",
        "loads.seismic.horizontal_coefficient: must be < 1, got 1.2",
    ),
    "negative_kh": (
        "[loads.seismic]\nhorizontal_coefficient = -0.1\n",
        "loads.seismic.horizontal_coefficient: must be >= 0, got -0.1",
    ),
    "load_off_the_surface": (
        "[[loads.strip]]\nname = \"footing\"\nx_start_m = 55.0\nx_end_m = 65.0\npressure_pa = 50e3\n",
        "loads.strip[0].x_end_m: 65 m is off the ground surface, which spans x = 0 to 60 m",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_water_and_load_input_exits_2_with_one_line(case, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    addition, message = BAD_INPUTS[case]
    text = (REPO / "studies" / "quickstart.toml").read_text()
    if addition.startswith("[loads"):
        text = text.replace('[loads]\ngravity_m_s2 = [0.0, -10.0]\n', '[loads]\ngravity_m_s2 = [0.0, -10.0]\n\n' + addition)
    else:
        text = text.replace("[loads]", addition + "\n[loads]")
    study = tmp_path / "study.toml"
    study.write_text(text)
    result = CliRunner().invoke(app, [str(study), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2, result.output
    assert result.stderr == f"error: {study}: {message}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.toml"]


def test_strip_load_fos_against_prandtl(tmp_path):
    """studies/strip_load.toml (h = 0.25 m): FOS = (2 + pi) cu / q within 3% (docs/verification.md
    has three spacings)."""
    study = parse_study((REPO / "studies" / "strip_load.toml").read_text())
    outcome = run_study(study, tmp_path, RunOptions(workers=2))
    assert outcome.criteria_agree
    assert abs(outcome.fos / prandtl_fos(study) - 1.0) < 0.03


@pytest.mark.slow  # a whole sweep (45-90 s); python -m verification.water_and_loads prints it
def test_drawdown_sweep_against_griffiths_and_lane(tmp_path):
    """studies/drawdown.toml: FOS within 3% of Griffiths & Lane (1999, Fig. 15) at every L / H, the
    minimum at L / H = 0.7."""
    study = parse_study((REPO / "studies" / "drawdown.toml").read_text())
    run_study(study, tmp_path, RunOptions(workers=2))
    height = study.geometry.slope.height_m
    with xr.open_dataset(tmp_path / "study.nc") as ds:
        ratios = [round((height - float(level)) / height, 6) for level in ds["phreatic_level_m"].values]
        fos = ds["fos"].values
    for ratio, value in zip(ratios, fos):
        assert abs(value / DRAWDOWN_REFERENCE[ratio] - 1.0) < 0.03, (ratio, value)
    assert ratios[int(np.argmin(fos))] == 0.7


@pytest.mark.slow  # a whole sweep (45-90 s); python -m verification.water_and_loads prints it
def test_seismic_sweep_falls_with_kh_to_one_at_the_critical_coefficient(tmp_path):
    """studies/seismic.toml (Loukidis et al. 2003): FOS falls monotonically with kh and is 1 within 5%
    at kc = 0.432."""
    study = parse_study((REPO / "studies" / "seismic.toml").read_text())
    run_study(study, tmp_path, RunOptions(workers=2))
    with xr.open_dataset(tmp_path / "study.nc") as ds:
        kh = ds["horizontal_coefficient"].values
        fos = ds["fos"].values
    assert np.all(np.diff(fos) < 0.0)
    assert kh[-1] == SEISMIC_KC and abs(fos[-1] - 1.0) < 0.05


@pytest.mark.parametrize("water, field, height_m", [
    ("phreatic_level_m = 100.0", "phreatic_level_m", 95.0),  # over the toe at y = 5 m
    ("phreatic_level_m = 8.0", "phreatic_level_m", 3.0),
    ("phreatic_line_m = [[0.0, 14.0], [40.0, 14.0], [60.0, 5.5]]", "phreatic_line_m", 9.0),
    ("phreatic_level_m = 100.0\npond_level_m = 100.0", None, None),  # a lake over the slope
    ("phreatic_level_m = 5.8", None, None),  # within a particle spacing of the toe
    ("phreatic_line_m = [[0.0, 14.0], [40.0, 5.5], [60.0, 5.5]]", None, None),
])
def test_water_above_the_ground_without_a_pond_is_named(water, field, height_m):
    """A piezometric line over unponded ground (more than a spacing above it) gets one warning naming
    the field and how high the water stands (sampled on 512 abscissae: within 0.2 m here)."""
    text = (REPO / "studies" / "quickstart.toml").read_text().replace("[loads]", f"[water]\n{water}\n\n[loads]")
    warnings = water_above_ground_warnings(parse_study(text))
    if field is None:
        assert warnings == []
        return
    assert len(warnings) == 1 and warnings[0].startswith(f"warning: water.{field}: the water stands "), warnings
    stands_m = float(warnings[0].split("stands ")[1].split(" m above")[0])
    assert stands_m == pytest.approx(height_m, abs=0.2)


def test_ru_pore_pressure_is_ru_times_the_overburden():
    """u = ru gamma z in level ground (z below the surface at the particle's initial position)."""
    study = parse_study(SATURATED_GROUND.replace("saturated_density_kg_m3 = 2000.0\n", "").replace(
        "phreatic_level_m = 5.0", "ru = 0.4"))
    scene = build_scene(study)
    depth = 5.0 - scene.node_xy_m[:, 1]
    np.testing.assert_allclose(scene.node_pore_pressure_pa, 0.4 * 1800.0 * 9.81 * depth, rtol=1e-12, atol=1e-9)


def test_line_load_goes_to_the_surface_particles_around_its_point():
    text = (REPO / "studies" / "strip_load.toml").read_text().replace(
        "[[loads.strip]]\nname = \"footing\"\nx_start_m = 10.0\nx_end_m = 12.0\npressure_pa = 150e3\n",
        "[[loads.line]]\nname = \"wall\"\nx_m = 11.1\nforce_n_m = 40e3\n")
    scene = build_scene(parse_study(text))
    loaded = np.flatnonzero(scene.node_load_n[:, 1])
    assert scene.node_load_n.sum(axis=0) == pytest.approx([0.0, -40e3])
    assert sorted(scene.node_xy_m[loaded, 0].tolist()) == pytest.approx([11.0, 11.25])
    assert (scene.node_load_n[:, 1] * scene.node_xy_m[:, 0]).sum() == pytest.approx(-40e3 * 11.1)


def test_a_material_with_its_own_piezometric_line_takes_its_pore_pressure_from_it():
    """A perched water table: the upper layer (y > 3 m) has its own line at 4.5 m, the ground below
    the study's line at 2 m; pore pressure and saturated density follow each particle's line."""
    text = SATURATED_GROUND.replace("phreatic_level_m = 5.0", "phreatic_level_m = 2.0") + """
[[materials]]
name = "upper"
model = "elastic"
density_kg_m3 = 1700.0
saturated_density_kg_m3 = 1900.0
youngs_modulus_pa = 20e6
poisson_ratio = 0.3
region_m = [[-1.0, 3.0], [11.0, 3.0], [11.0, 6.0], [-1.0, 6.0]]
phreatic_line_m = [[0.0, 4.5], [10.0, 4.5]]
"""
    # the [[materials]] table appended after the stages is still the materials array of tables
    scene = build_scene(parse_study(text))
    y = scene.node_xy_m[:, 1]
    upper = scene.node_material == 1
    expected = np.where(upper, GAMMA_W * np.maximum(4.5 - y, 0.0), GAMMA_W * np.maximum(2.0 - y, 0.0))
    np.testing.assert_allclose(Simulation(scene).pore_pressure_pa, expected, rtol=1e-12, atol=1e-9)
    density = np.where(upper, np.where(y <= 4.5, 1900.0, 1700.0), np.where(y <= 2.0, 2000.0, 1800.0))
    np.testing.assert_array_equal(scene.node_properties["density_kg_m3"], density)


def test_load_ramp_grows_the_load_and_relaxation_waits_for_it(tmp_path):
    """With loads.ramp_time_s the strip load grows from zero over the first stage: the gravity state
    is the one of the load applied at once (elastic, to the tolerance), and the relaxation does not
    stop before the ramp ends."""
    text = (REPO / "studies" / "strip_load.toml").read_text().replace("spacing_m = 0.25", "spacing_m = 0.5")
    gravity_only = text.split('[[stages]]\nname = "srf"')[0].split("[[monitors]]")[0]
    states = []
    for name, text_of_case in (("at_once", gravity_only),
                             ("ramped", gravity_only.replace("[loads]\n", "[loads]\nramp_time_s = 3.0\n"))):
        run = run_study(parse_study(text_of_case), tmp_path / name)
        with xr.open_dataset(run.paths[0]) as gravity:
            states.append((gravity["particle_syy"].values, float(gravity["time"].values[-1])))
    assert states[1][1] >= 3.0 > states[0][1]
    assert np.abs(states[1][0] - states[0][0]).max() < 1e-3 * np.abs(states[0][0]).max()
