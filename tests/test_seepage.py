"""Steady seepage: the solver against exact fields (patch test, radial flow, the rectangular dam),
the study file's conditions and their errors, and the pore pressure the particles carry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from spfem_core.cloud import particles_in_polygon
from spfem_core.mesh import triangulate
from spfem_core.seepage import (
    FlowProblem,
    conductivity_tensor,
    element_relative_permeability,
    solve_steady_flow,
)
from verification.seepage import (
    PK_EXIT_Y_M,
    PK_FREE_SURFACE,
    flow_of,
    quarter_annulus,
    rectangular_dam,
    rectangular_dam_text,
    sheet_pile_exact,
    sheet_pile_text,
)
from workflows.cases import RunOptions
from workflows.scene import build_scene
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("k1, k2, angle", [(1e-5, 1e-5, 0.0), (2e-5, 5e-7, 30.0)])
def test_a_linear_head_is_exact_on_a_jittered_cloud(k1, k2, angle):
    """Patch test: h = 13 + 0.2 x - 0.5 y on the boundary gives it inside to round-off, and the Darcy
    velocity -K grad h in every triangle, isotropic or anisotropic at 30 degrees."""
    xy = particles_in_polygon(np.array([[0, 0], [6, 0], [6, 4], [0, 4]], float), 0.5, jitter=0.25, seed=3)
    elem = triangulate(xy, 0.5, 1.5).elem_nodes
    exact = 13.0 + 0.2 * xy[:, 0] - 0.5 * xy[:, 1]  # above the domain: saturated
    edge = (xy[:, 0] < 1e-9) | (xy[:, 0] > 6 - 1e-9) | (xy[:, 1] < 1e-9) | (xy[:, 1] > 4 - 1e-9)
    k = conductivity_tensor(k1, k2, angle)
    problem = FlowProblem(xy, elem, np.broadcast_to(k, (elem.shape[0], 2, 2)), np.where(edge, exact, np.nan),
                          np.zeros(len(xy)), np.zeros(len(xy), bool))
    solution = solve_steady_flow(problem)
    assert (~edge).sum() > 50
    np.testing.assert_allclose(solution.head_m, exact, atol=1e-11)
    np.testing.assert_allclose(solution.elem_darcy_velocity_m_s, np.broadcast_to(-k @ [0.2, -0.5], (elem.shape[0], 2)),
                               rtol=1e-9, atol=1e-20)


def test_a_triangle_the_water_table_crosses_conducts_in_proportion_to_its_saturated_area():
    """psi = (1, -1, -1) at the vertices: a quarter of the area is saturated (psi >= 0), so k_r =
    k_r0 + (1 - k_r0) / 4; with a band, the mean of the linear front over the triangle."""
    elem = np.array([[0, 1, 2]])
    assert element_relative_permeability(np.array([1.0, -1.0, -1.0]), elem, 1e-3, 0.0)[0] == pytest.approx(
        1e-3 + (1 - 1e-3) * 0.25)
    assert element_relative_permeability(np.array([2.0, 3.0, 4.0]), elem, 1e-3, 0.5)[0] == 1.0
    assert element_relative_permeability(np.array([-2.0, -3.0, -4.0]), elem, 1e-3, 0.5)[0] == 1e-3


@pytest.mark.parametrize("band_m", [0.0, 1.0, 1e6])
def test_the_mean_relative_permeability_makes_no_overflow_whatever_the_band(band_m):
    """Triangles with two equal pressure heads (a zero-width piece of the triangular distribution),
    flat ones, and random ones: each piece of the mean is evaluated only where it applies, so a band of
    1e6 m (whose pieces divided by 1e-300 where they do not apply) warns of nothing (warnings are
    errors here), and k_r is the mean of k_r(psi) over the triangle, by sampling."""
    rng = np.random.default_rng(5)
    psi = rng.normal(0.0, 3.0, (300, 3))
    psi[::3, 1] = psi[::3, 2]
    psi[1::3, 0] = psi[1::3, 1]
    psi[::10] = 0.0
    kr = element_relative_permeability(psi.ravel(), np.arange(psi.size).reshape(-1, 3), 1e-3, band_m)
    a, b = rng.random((2, 4000))
    fold = a + b > 1.0
    a, b = np.where(fold, 1.0 - a, a), np.where(fold, 1.0 - b, b)  # uniform over the triangle
    values = psi[:, :1] + a * (psi[:, 1:2] - psi[:, :1]) + b * (psi[:, 2:3] - psi[:, :1])
    pointwise = np.where(values >= 0.0, 1.0, 1e-3) if band_m == 0.0 else \
        np.clip(1e-3 + (1.0 - 1e-3) * (1.0 + values / band_m), 1e-3, 1.0)
    np.testing.assert_allclose(kr, pointwise.mean(axis=1), atol=0.03)


def test_radial_flow_converges_to_the_closed_form_at_second_order():
    """A quarter annulus r = 2-10 m: the discharge error falls about 4 times per halving of h (at
    least 3.4 times), below 5e-4 at h = 0.25 m."""
    errors = [abs(quarter_annulus(h)[0]) for h in (0.5, 0.25, 0.125)]
    assert errors[1] < 5e-4
    assert errors[0] / errors[1] > 3.4 and errors[1] / errors[2] > 3.4


def test_flow_under_a_sheet_pile_approaches_pavlovskys_closed_form():
    """s / T = 0.5 (q / kH = 0.5 exactly): +1.3% at h = 0.25 m, halving with h (the flow is singular
    at the pile's tip: first order)."""
    coarse, fine = (flow_of(sheet_pile_text(h, 10.0, 5.0, 10.0)) for h in (0.5, 0.25))
    q = [dict(zip(f.conditions, f.condition_inflow_m2_s()))["below_tip"] / (1e-5 * 10.0) for f in (coarse, fine)]
    exact = sheet_pile_exact(10.0, 5.0)
    assert exact == pytest.approx(0.5, abs=1e-12)
    assert 0.0 < q[1] / exact - 1.0 < 0.02
    assert (q[0] - exact) / (q[1] - exact) == pytest.approx(2.0, rel=0.15)


def test_the_rectangular_dam_passes_dupuits_discharge_and_polubarinova_kochinas_free_surface():
    """H1 = 10 m, H2 = 2 m, L = 10 m at h = 0.5 m: in = out = Dupuit's q within 0.1% (k_r0 = 1e-3 lets
    a trickle through the dry soil), the exit point within one spacing of the exact 3.94 m and above the
    tailwater, the free surface within 0.03 m of the exact one."""
    result = rectangular_dam(0.5)
    assert result["inflow_ratio"] == pytest.approx(1.0, abs=1e-3)
    assert result["outflow_ratio"] == pytest.approx(result["inflow_ratio"], rel=1e-5)  # the tolerance 1e-6
    assert result["exit_y_m"] > 2.0 and abs(result["exit_y_m"] - PK_EXIT_Y_M) <= 0.5
    np.testing.assert_allclose(result["surface_m"], [y for _, y in PK_FREE_SURFACE], atol=0.03)


def _without_upstream(text: str) -> str:
    start = text.index('[[seepage.boundary]]\nname = "upstream"')
    return text[:start] + text[text.index("[[seepage.boundary]]", start + 1):]


DAM = (_without_upstream(rectangular_dam_text(0.5)) + '\n[water]\npond_level_m = 10.0\npond_x_max_m = 0.0\n').replace(
    "density_kg_m3 = 2000.0", "density_kg_m3 = 1800.0\nsaturated_density_kg_m3 = 2000.0")
"""The rectangular dam with its upstream head set by ponded water against the upstream face alone."""


def test_the_particles_carry_the_flows_pore_pressure_and_weigh_saturated_below_the_water_table():
    study = parse_study(DAM)
    scene = build_scene(study)
    flow = flow_of(DAM)
    psi = flow.solution.pressure_head_m(flow.node_xy_m)
    np.testing.assert_allclose(scene.node_pore_pressure_pa, 9810.0 * np.maximum(psi, 0.0))
    assert set(np.unique(scene.node_properties["density_kg_m3"])) == {1800.0, 2000.0}
    np.testing.assert_array_equal(scene.node_properties["density_kg_m3"] == 2000.0, psi >= 0.0)
    assert scene.pond_x_range_m == (-math.inf, 0.25)  # half a spacing of slack: the face stays wet as it moves


def test_a_study_writes_its_flow_and_every_stage_uses_it(tmp_path, monkeypatch):
    """The gravity stage of the dam: seepage.nc (mass balance closed, the pond on the upstream face
    alone) and seepage.png beside the stage file, whose pore pressures are the flow's; the flow is
    solved once (the report's section on the one the process remembers: ``scene.water_flow``), and the
    scene's flow is the one written."""
    import workflows.seepage.flow as flow_module
    from workflows.scene import water_flow

    water_flow.cache_clear()  # (an earlier test's remembered flow of the same study)
    solve, solved = flow_module._flow, []
    monkeypatch.setattr(flow_module, "_flow", lambda *inputs: solved.append(inputs) or solve(*inputs))
    run_study(parse_study(DAM), tmp_path, RunOptions())
    assert len(solved) == 1
    with xr.open_dataset(tmp_path / "seepage.nc") as seepage, xr.open_dataset(tmp_path / "run.nc") as run:
        assert seepage.attrs["converged"] == 1
        assert seepage.attrs["inflow_m2_s"] == pytest.approx(seepage.attrs["outflow_m2_s"], rel=1e-5)
        inflow = dict(zip(seepage["condition"].values, seepage["condition_inflow"].values))
        assert inflow["pond"] == pytest.approx(-(inflow["face"] + inflow["tailwater"]), rel=1e-5)
        assert inflow["pond"] == pytest.approx(1e-5 * (10.0**2 - 2.0**2) / 20.0, rel=1e-3)  # Dupuit's q
        np.testing.assert_allclose(run["particle_pore_pressure"].values, seepage["pore_pressure"].values)
        assert seepage["phreatic_x"].sizes["segment"] > 10
    assert (tmp_path / "seepage.png").is_file()


@pytest.mark.parametrize("change, field", [
    ("permeability_m_s = 1e-05\n", "materials[0].permeability_m_s"),
    ('condition = "seepage_face"\nx_min_m = 10.0\n', "seepage.boundary[1]"),
    ("[seepage]\n", "water.phreatic_level_m"),
])
def test_a_seepage_study_that_cannot_be_solved_names_the_field(change, field):
    """A material without permeability; a seepage face whose box misses the boundary; a line beside
    the computed water."""
    if field.startswith("materials"):
        text = rectangular_dam_text(0.5).replace(change, "")
    elif field.startswith("seepage"):
        text = rectangular_dam_text(0.5).replace(change, 'condition = "seepage_face"\nx_min_m = 20.0\n')
    else:
        text = rectangular_dam_text(0.5).replace(change, "[water]\nphreatic_level_m = 5.0\n" + change)
    with pytest.raises(StudyError) as error:
        build_scene(parse_study(text))
    assert error.value.field == field


def test_a_tolerance_finer_than_double_precision_is_refused_naming_it():
    """1e-300 of the head range asks for changes a billion billion times below the spacing of doubles
    at the heads: refused as the tolerance it is, before a mesh is made, not after max_iterations."""
    text = rectangular_dam_text(0.5).replace("[seepage]\n", "[seepage]\ntolerance = 1e-300\n")
    with pytest.raises(StudyError, match="finer than double precision resolves heads of 12 m") as error:
        parse_study(text)
    assert error.value.field == "seepage.tolerance" and "give at least 1e-12" in error.value.problem
    assert parse_study(text.replace("1e-300", "1e-15")).seepage.tolerance == 1e-15  # resolvable: tried


def test_an_iteration_stalled_at_round_off_blames_the_tolerance(monkeypatch):
    """A tolerance above the spacing of doubles but within the round-off of the solve: the changes stall
    there (the solver asked for exact convergence), and the message names the tolerance, not
    max_iterations; a tolerance far above the round-off keeps the max_iterations message."""
    from workflows.seepage import flow

    monkeypatch.setattr(flow, "solve_steady_flow", lambda problem, tolerance, max_iterations:
                        solve_steady_flow(problem, 0.0, max_iterations))
    text = rectangular_dam_text(0.5).replace("[seepage]\n", "[seepage]\nmax_iterations = 100\ntolerance = 3e-16\n")
    with pytest.raises(StudyError, match="finer than the round-off of the heads") as error:
        build_scene(parse_study(text))
    assert error.value.field == "seepage.tolerance"
    with pytest.raises(StudyError, match="did not settle in 100 iterations") as error:
        build_scene(parse_study(text.replace("3e-16", "1e-6")))
    assert error.value.field == "seepage.max_iterations"


@pytest.mark.parametrize("condition, flux_m_s", [("inflow", 1e3), ("inflow", -2e-4), ("infiltration", 1.0)])
def test_a_flux_no_ground_can_carry_is_refused_before_the_flow_is_solved(condition, flux_m_s):
    """1e3 m/s into ground of 1e-5 m/s needs a gradient of 1e8 where it enters: it was solved, and the
    first step of the gravity stage diverged.  Above ten times the largest permeability (a gradient of
    10, ten times soil's critical gradient) the flux is refused, naming it; at the limit it is taken."""
    entry = f'[[seepage.boundary]]\nname = "spring"\ncondition = "{condition}"\ny_max_m = 0.0\nflux_m_s = '
    with pytest.raises(StudyError, match="would need a hydraulic gradient of at least") as error:
        parse_study(rectangular_dam_text(0.5) + entry + f"{flux_m_s}\n")
    assert error.value.field == "seepage.boundary[3].flux_m_s" and "give at most 0.0001 m/s" in error.value.problem
    assert parse_study(rectangular_dam_text(0.5) + entry + "1e-4\n").seepage.boundary[3].flux_m_s == 1e-4


def test_no_head_anywhere_is_refused_and_a_flux_must_find_an_edge():
    no_head = rectangular_dam_text(0.5).replace('condition = "total_head"', 'condition = "no_flow"').replace(
        'condition = "seepage_face"', 'condition = "no_flow"').replace("total_head_m = 10.0\n", "").replace(
        "total_head_m = 2.0\n", "")
    with pytest.raises(StudyError, match="fixes a head") as error:
        build_scene(parse_study(no_head))
    assert error.value.field == "seepage.boundary"
    one_point = rectangular_dam_text(0.5) + ('[[seepage.boundary]]\nname = "rain"\ncondition = "infiltration"\n'
                                             'flux_m_s = 1e-6\nx_min_m = 10.0\ny_min_m = 12.0\n')
    with pytest.raises(StudyError, match="no edge") as error:
        build_scene(parse_study(one_point))
    assert error.value.field == "seepage.boundary[3]"


def test_ponded_water_loads_only_the_surface_within_its_abscissae():
    """The pond of the dam stands against its upstream face (x <= 0) alone: after one step, the water's
    horizontal push on the particles is gamma_w H1^2 / 2 in +x (the pore pressure's own forces sum to
    zero over each triangle); the downstream face, below the pond's level too, is dry."""
    from workflows.stages.running import begin_stage, new_simulation

    study = parse_study(DAM)
    sim = new_simulation(study, build_scene(study), threads=1)
    begin_stage(study, sim, 0)
    sim.run(1.5 * sim.dt_s, damping=0.0)
    push = sim.scratch.external_force_n[:, 0].sum()
    assert push == pytest.approx(9810.0 * 10.0**2 / 2.0, rel=2e-3)


PERMEABILITY_FIELD = ('\n[random_field]\nseed = 2\n[[random_field.properties]]\nname = "k"\nmaterial = "clay"\n'
                      'property = "permeability_m_s"\ndistribution = "lognormal"\ncov = 1.0\ntheta_x_m = 4.0\n')


def _dam(spacing_m: float) -> str:
    from verification.seepage import DAM_STUDY

    return DAM_STUDY.read_text().replace("spacing_m = 0.25", f"spacing_m = {spacing_m!r}")


def test_a_permeability_field_changes_the_flow_of_each_realisation_and_only_the_flow():
    """A lognormal permeability field in the shipped dam: two realisations give two flows (another exit,
    other pore pressures), each the pore pressure its particles carry; the core gets no permeability."""
    from workflows.seepage.flow import study_flow

    flows, scenes = [], []
    for realisation in (0, 1):
        study = parse_study(_dam(0.5) + PERMEABILITY_FIELD.replace("seed = 2", f"seed = 2\nrealisation = {realisation}"))
        flows.append(study_flow(study))
        scenes.append(build_scene(study))
        np.testing.assert_allclose(scenes[-1].node_pore_pressure_pa, flows[-1].pore_pressure_pa())
        assert "permeability_m_s" not in scenes[-1].node_properties
    assert not np.allclose(flows[0].pore_pressure_pa(), flows[1].pore_pressure_pa())
    homogeneous = study_flow(parse_study(_dam(0.5)))
    assert not np.allclose(flows[0].pore_pressure_pa(), homogeneous.pore_pressure_pa())


def test_permeability_varies_only_with_seepage():
    text = rectangular_dam_text(0.5).replace("[seepage]", "[unused]").split("[unused]")[0]  # no [seepage]
    text = text.replace("permeability_m_s = 1e-05\n", "") + PERMEABILITY_FIELD.replace('"clay"', '"soil"')
    with pytest.raises(StudyError, match="permeability_m_s with \\[seepage\\]") as error:
        parse_study(text)
    assert error.value.field == "random_field.properties[0].property"


def test_a_probabilistic_study_of_a_permeability_field_runs_each_realisation_on_its_own_flow(tmp_path):
    """Three realisations of the dam at h = 0.5 m judged at F = 1.05 (near its FOS): each relaxes its own
    gravity state (its pore pressures differ) and gets a verdict."""
    text = _dam(0.5) + PERMEABILITY_FIELD + "\n[probabilistic]\nrealisations = 3\nfactor = 1.05\n"
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert outcome.n_realisations == 3 and outcome.n_undecided == 0 and outcome.runs_made == 3
    assert not (tmp_path / "gravity").exists()  # one gravity state per realisation, in memory


def test_the_reservoir_level_and_a_permeability_ratio_are_sweepable():
    """A [sweep] over the dam's reservoir level and its clay's anisotropy makes cases whose flows
    differ: a higher reservoir puts more pore pressure in the dam, whatever the anisotropy."""
    from workflows.seepage.flow import study_flow
    from workflows.study.reading import sweep_cases

    text = _dam(0.5) + ('\n[sweep]\n[[sweep.axes]]\npath = "water.pond_level_m"\nvalues = [3.0, 5.1]\n'
                        '[[sweep.axes]]\npath = "materials.clay.permeability_ratio"\nvalues = [1.0, 0.1]\n')
    cases = sweep_cases(parse_study(text))
    total = {case.values["pond_level_m"]: [] for case in cases}
    for case in cases:
        total[case.values["pond_level_m"]].append(study_flow(case.study).pore_pressure_pa().sum())
    assert len(cases) == 4
    assert all(high > low for high, low in zip(total[5.1], total[3.0]))
    assert total[5.1][0] != total[5.1][1]  # the anisotropy moves the water table


def test_a_failed_realisation_of_a_permeability_field_draws_its_figure_and_the_study_finishes(tmp_path):
    """Two realisations of the dam's permeability field judged at F = 3 (both fail): the failed
    realisation's figure asked the scene for the permeability, which the scene leaves to the flow
    (KeyError, after probabilistic.nc was written: the study could never finish); now the figure shows
    the field, log-scaled, beside the mechanism."""
    text = _dam(0.5) + PERMEABILITY_FIELD + "\n[probabilistic]\nrealisations = 2\nfactor = 3.0\n"
    outcome = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert outcome.n_failed == 2 and (tmp_path / "probabilistic.nc").is_file()
    assert sorted(path.name for path in tmp_path.glob("failed_*.png")) == [
        "failed_realisation_00000.png", "failed_realisation_00001.png"]


@pytest.mark.parametrize("rain_over_k, taken_over_k", [(2.0, 1.0), (0.5, 0.5)])
def test_rain_on_a_column_is_taken_up_to_the_conductivity_and_the_rest_runs_off(rain_over_k, taken_over_k):
    """A 1 m wide column 5 m high over a water table at its base, rain q on its top: the ground takes at
    most its conductivity (the saturated column under a unit gradient, h = y), the rest runs off with
    the top held at atmospheric pressure; a lighter rain all soaks in.  Before, the top's head rose
    above the ground with nothing to hold it."""
    k = 1e-5
    xy = particles_in_polygon(np.array([[0, 0], [1, 0], [1, 5], [0, 5]], float), 0.25)
    elem = triangulate(xy, 0.25, 1.5).elem_nodes
    base, top = xy[:, 1] < 1e-9, xy[:, 1] > 5 - 1e-9
    rain = np.zeros(len(xy))
    order = np.argsort(xy[top, 0])
    x_top = xy[top, 0][order]
    share = np.zeros(x_top.size)  # each top particle half of each neighbouring edge
    share[:-1] += 0.5 * np.diff(x_top)
    share[1:] += 0.5 * np.diff(x_top)
    rain[np.flatnonzero(top)[order]] = rain_over_k * k * share
    problem = FlowProblem(xy, elem, np.broadcast_to(conductivity_tensor(k, k, 0.0), (elem.shape[0], 2, 2)),
                          np.where(base, 0.0, np.nan), rain, np.zeros(len(xy), bool), unsaturated_band_m=1.0,
                          node_infiltration=top)
    solution = solve_steady_flow(problem)
    assert solution.converged
    taken = solution.node_inflow_m2_s[top].sum()
    assert taken == pytest.approx(taken_over_k * k, rel=1e-3)
    assert solution.pressure_head_m(xy)[top].max() <= 1e-6  # never water standing on the ground
    if rain_over_k > 1.0:
        np.testing.assert_allclose(solution.head_m, xy[:, 1], atol=1e-4)  # saturated, unit gradient
        assert solution.node_held[top].all()


def _perched(rain_m_s: str) -> str:
    """The shipped perched-water study at h = 1 m under a rain of ``rain_m_s`` (as written)."""
    text = (REPO / "studies" / "seepage_perched.toml").read_text().replace("spacing_m = 0.5", "spacing_m = 1.0")
    return text.replace("flux_m_s = 2e-8", f"flux_m_s = {rain_m_s}")


def test_rain_the_perched_slope_cannot_carry_saturates_it_to_its_surface_and_runs_off():
    """The shipped perched study under a rain 500 times heavier (1e-5 m/s, the sand's conductivity):
    before, heads several metres above the crest with 'settled' printed, or no steady state; now the
    rain particles the ground cannot feed hold atmospheric pressure, no particle of the ground surface
    carries water above it, and the rain given is the rain taken plus the runoff."""
    from spfem_core.geometry import surface_height_m
    from workflows.seepage.flow import study_flow
    from workflows.seepage.results import flow_line

    study = parse_study(_perched("1e-5"))
    flow = study_flow(study)
    xy = flow.node_xy_m
    surface = np.abs(xy[:, 1] - surface_height_m(study.geometry.polygon_m, xy[:, 0])) < 1e-6
    assert flow.solution.converged and flow.solution.pressure_head_m(xy)[surface].max() <= 0.01
    rain = flow.problem.infiltration()
    given = flow.problem.node_inflow_m2_s[rain].sum()
    taken = flow.solution.node_inflow_m2_s[rain].sum()
    assert flow.runoff_m2_s() > 0.1 * given and flow.runoff_m2_s() + taken == pytest.approx(given, rel=1e-9)
    assert "of the rain runs off" in flow_line(flow)


@pytest.mark.parametrize("changes, field", [
    # rain on the crest alone, the slope face left no-flow: the perched water rises through the face
    ({"y_min_m = 5.0\nflux": "y_min_m = 14.99\nflux", 'condition = "seepage_face"': 'condition = "no_flow"',
      "flux_m_s = 2e-8": "flux_m_s = 1e-6"}, "seepage.boundary"),
    # a prescribed inflow the ground cannot take: no infiltration review applies to it
    ({'condition = "infiltration"': 'condition = "inflow"', "flux_m_s = 2e-8": "flux_m_s = 1e-5"},
     "seepage.boundary[0]"),
])
def test_water_standing_above_the_ground_that_no_condition_holds_is_refused_naming_the_entry(changes, field):
    """Before, these 'settled' with heads up to 1,000 m above the ground surface (pressure heads of
    hundreds of metres); now one line names the condition there and the remedy."""
    text = _perched("2e-8")
    for old, new in changes.items():
        text = text.replace(old, new)
    with pytest.raises(StudyError, match="above the ground surface") as error:
        build_scene(parse_study(text))
    assert error.value.field == field
