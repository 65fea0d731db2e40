"""Transient unsaturated seepage: Srivastava & Yeh's analytical solution itself, the solver against
it and against Lu & Griffiths' steady profiles, its conditions in time (ponding rain, a drawdown,
seepage faces), anisotropy, and the mass balance of every run.  The convergence orders are slow."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from spfem_core.cloud import particles_in_polygon
from spfem_core.flow_system import conductivity_tensor
from spfem_core.geometry import surface_height_m
from spfem_core.mesh import triangulate
from spfem_core.seepage import FlowProblem, solve_steady_flow
from spfem_core.soil_water import Gardner, VanGenuchten
from spfem_core.transient_seepage import (
    FlowNotConverged,
    HeadBoundary,
    History,
    ReservoirBoundary,
    TransientProblem,
    TransientSettings,
    boundary_flux_weights_m,
    hydrostatic_head_m,
    solve_transient_flow,
)
from verification.srivastava_yeh import (
    Column,
    Layer,
    SrivastavaYeh,
    laplace_pressure_head_m,
    steady_pressure_head_m,
)
from verification.transient_seepage import (
    HOMOGENEOUS,
    HOUR_S,
    TWO_LAYERS,
    WATER_CONTENT_RANGE,
    column_problem,
    drawdown_bank,
    dry_limit_column,
    lu_griffiths,
    observed_orders,
    ponding_column,
    profile_run,
    spacing_convergence,
    step_convergence,
)

BALANCE = 1e-7
"""The closure every run must reach: its cumulative in - out - stored over the water moved, and each
step's over its own balance (the default balance_tolerance bounds the latter)."""


def _closed(solution) -> None:
    assert solution.balance_fraction()[-1] <= BALANCE
    assert solution.step_balance_fractions().max() <= BALANCE


# --- the analytical solution -------------------------------------------------------------------------

@pytest.mark.parametrize("column", [HOMOGENEOUS, TWO_LAYERS], ids=["homogeneous", "two layers"])
def test_the_series_agrees_with_the_inverted_laplace_transform(column):
    """Srivastava & Yeh's series (residues) and the numerical inversion of the same problem's Laplace
    transform, two evaluations that share nothing but the problem, agree to 1e-8 m from 30 min to steady state;
    every eigenfunction has one more interior zero than the last (none missed, Sturm) and Parseval's sum is
    complete to the truncation of the series (the terms that decay by e^-40 within a minute left out: 6e-8 and
    7e-7 missing)."""
    series = SrivastavaYeh(column, 0.5 * HOUR_S)
    z = np.linspace(0.0, column.height_m, 41)
    for t in (0.5 * HOUR_S, 3 * HOUR_S, 24 * HOUR_S, 1e7):
        assert np.max(np.abs(series.pressure_head_m(z, t) - laplace_pressure_head_m(column, z, t))) < 1e-8
    np.testing.assert_allclose(series.pressure_head_m(z, 1e8), steady_pressure_head_m(column, z, column.flux_m_s),
                               atol=1e-12)
    assert np.array_equal(series.interior_zeros(), np.arange(series.eigenvalues_1_s.size))
    assert abs(SrivastavaYeh(column, 60.0).parseval_deficit()) < 1e-5


def test_the_homogeneous_series_has_srivastava_and_yehs_eigenvalues_and_coefficients():
    """One layer: tan(lambda L) = -2 lambda / alpha, mu = D (lambda^2 + alpha^2 / 4), and with w_n = sin(lambda z)
    the coefficients 4 (q0 - qA) / K_s e^(alpha L / 2) sin(lambda L) / (1 + alpha L / 2 + 2 lambda^2 L / alpha)."""
    column = HOMOGENEOUS
    series = SrivastavaYeh(column, HOUR_S)
    layer = column.layers[0]
    d = layer.saturated_conductivity_m_s / (column.alpha_1_m * layer.water_content_range)
    lam = np.sqrt(series.eigenvalues_1_s / d - column.alpha_1_m**2 / 4.0)
    length, alpha = column.height_m, column.alpha_1_m
    np.testing.assert_allclose(np.tan(lam * length), -2.0 * lam / alpha, rtol=1e-7, atol=1e-9)
    change = (column.initial_flux_m_s - column.flux_m_s) / layer.saturated_conductivity_m_s
    closed = 4.0 * change * math.exp(alpha * length / 2) * np.sin(lam * length) / (
        1.0 + alpha * length / 2 + 2.0 * lam**2 * length / alpha)
    coefficients, _ = series.coefficients
    np.testing.assert_allclose(coefficients / lam, closed, rtol=1e-9, atol=1e-12 * np.max(np.abs(closed)))


# --- the solver against closed forms -----------------------------------------------------------------

@pytest.mark.parametrize("column, tolerance_m", [(HOMOGENEOUS, 0.06), (TWO_LAYERS, 0.02)],
                         ids=["homogeneous", "two layers"])
def test_infiltration_toward_a_water_table_follows_srivastava_and_yeh(column, tolerance_m):
    """h = 0.25 m, the default step control: the pressure heads within 0.06 m (homogeneous; 0.044 m at 1 h,
    where the front is sharpest) and 0.02 m (two layers) of the closed form at 1, 3 and 6 h, the flux raised
    from 0.1 to 0.9 K_s; the balance closed."""
    run = profile_run(column, 0.25, np.array([1.0, 3.0, 6.0]) * HOUR_S)
    assert np.all(run.error_m < tolerance_m)
    assert run.top_m[-1] > run.top_m[0]  # the surface wets
    _closed(run.solution)


@pytest.mark.parametrize("ratio, tolerance_m", [(0.5, 0.005), (-0.005, 0.1)], ids=["infiltration", "evaporation"])
def test_a_steady_flux_reaches_lu_and_griffiths_profile(ratio, tolerance_m):
    """5 m above the water table at h = 0.25 m, from hydrostatic water: infiltration at 0.5 K_s within 0.005 m
    of psi = ln[q/K_s + (1 - q/K_s) e^(-alpha z)] / alpha; evaporation at 0.005 K_s (psi -6.3 m at the top, the
    steepest profile) within 0.1 m (0.083 m, falling 4 times per halving of h: verification/transient_seepage.py)."""
    result = lu_griffiths(ratio * 1e-6, spacing_m=0.25)
    assert result["error_m"] < tolerance_m
    _closed(result["solution"])


@pytest.mark.parametrize("k1, k2, angle", [(1e-5, 1e-5, 0.0), (2e-5, 5e-7, 30.0)])
def test_a_saturated_block_relaxes_to_the_steady_solvers_heads(k1, k2, angle):
    """A block whose boundary holds h = 13 + 0.2 x - 0.5 y (above the block: saturated, S_s = 1e-3 /m) from
    uniform heads: at long times the steady solution, the linear field to 1e-9 m, the same heads as the steady
    solver's, the Darcy velocity -K grad h in every triangle (anisotropic at 30 degrees too)."""
    xy = particles_in_polygon(np.array([[0, 0], [6, 0], [6, 4], [0, 4]], float), 0.5, jitter=0.25, seed=3)
    elem = triangulate(xy, 0.5, 1.5).elem_nodes
    exact = 13.0 + 0.2 * xy[:, 0] - 0.5 * xy[:, 1]
    edge = (xy[:, 0] < 1e-9) | (xy[:, 0] > 6 - 1e-9) | (xy[:, 1] < 1e-9) | (xy[:, 1] > 4 - 1e-9)
    k = np.broadcast_to(conductivity_tensor(k1, k2, angle), (elem.shape[0], 2, 2))
    curve = VanGenuchten(0.05, 0.40, 1.0, 2.0, 1e-3)
    boundaries = (HeadBoundary("edge", edge, History.constant(0.0), offset_m=exact),)
    problem = TransientProblem(xy, elem, k, np.zeros(elem.shape[0], dtype=np.int64), (curve,), boundaries,
                               np.full(len(xy), 12.0))
    solution = solve_transient_flow(problem, [1e9], TransientSettings(max_step_s=1e8))
    np.testing.assert_allclose(solution.head_m[-1], exact, atol=1e-9)
    steady = solve_steady_flow(FlowProblem(xy, elem, k, np.where(edge, exact, np.nan), np.zeros(len(xy)),
                                           np.zeros(len(xy), bool)))
    np.testing.assert_allclose(solution.head_m[-1], steady.head_m, atol=1e-9)
    np.testing.assert_allclose(solution.elem_darcy_velocity_m_s[-1], np.broadcast_to(-k[0] @ [0.2, -0.5],
                                                                                       (elem.shape[0], 2)), rtol=1e-6)
    _closed(solution)


def test_hydrostatic_water_stays_at_rest():
    """A column at hydrostatic pressure below and above its water table (no suction cap), the table held at its
    base and no flow on top: nothing moves (heads to 1e-12 m), no water in or out."""
    column = Column(1.0, (Layer(4.0, 1e-5, 0.34),), 0.0, 0.0)
    xy, problem = column_problem(column, 0.25, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0))
    solution = solve_transient_flow(problem, [HOUR_S, 10 * HOUR_S])
    np.testing.assert_allclose(solution.head_m, 0.0, atol=1e-12)
    assert np.max(np.abs(solution.boundary_cumulative_inflow_m2)) < 1e-15


def test_a_closed_domain_keeps_its_water():
    """No boundary condition at all (every boundary no-flow): the column's unsaturated water, its head higher
    on top, redistributes but none enters or leaves, its balance closes over the water moved, and the
    boundary flows are empty columns per time (they were a reshape error).  Water at rest there stays at
    rest (its balance's scale is 0: only the residual's rounding bounds it; it never converged)."""
    column = Column(1.0, (Layer(4.0, 1e-5, 0.34),), 0.0, 0.0)
    xy, problem = column_problem(column, 0.25, initial_head=lambda xy: -2.0 + 0.5 * xy[:, 1])
    closed = dataclasses.replace(problem, boundaries=())
    solution = solve_transient_flow(closed, [HOUR_S, 10 * HOUR_S])
    assert solution.boundary_inflow_m2_s.shape == (3, 0)
    assert solution.boundary_cumulative_inflow_m2.shape == (3, 0)
    assert solution.water_in_m2[-1] == 0.0 and solution.water_out_m2[-1] == 0.0
    assert np.ptp(solution.head_m[-1]) < 0.5 * np.ptp(solution.head_m[0])  # it moved
    _closed(solution)
    at_rest = solve_transient_flow(dataclasses.replace(closed, initial_head_m=np.full(len(xy), 1.0)), [HOUR_S])
    np.testing.assert_allclose(at_rest.head_m, 1.0, atol=1e-12)


def test_a_node_on_a_material_interface_stores_each_materials_water():
    """Two layers of different curves at one uniform pressure head: the lumped water sums each material's
    theta over its own area (the interface row of particles takes half from each)."""
    column = Column(1.0, (Layer(2.0, 1e-5, 0.34), Layer(2.0, 1e-5, 0.34)), 0.0, 0.0)
    curves = (Gardner(0.06, 0.40, 1.0), VanGenuchten(0.10, 0.45, 2.0, 1.5))
    xy, problem = column_problem(column, 0.25, curves=curves, initial_head=lambda xy: xy[:, 1] - 0.7)
    solution = solve_transient_flow(problem, [1.0], TransientSettings(initial_step_s=1.0))
    area = 2.0 * 0.5
    expected = area * (curves[0].water_content(-0.7) + curves[1].water_content(-0.7))
    assert solution.stored_water_m2[0] == pytest.approx(expected, rel=1e-12)


# --- conditions in time --------------------------------------------------------------------------------

def test_a_history_is_linear_between_its_points_and_its_mean_is_exact():
    rain = History(np.array([0.0, 10.0, 10.0, 30.0]), np.array([2.0, 2.0, 5.0, 1.0]))
    assert rain.at(-5.0) == 2.0 and rain.at(10.0) == 5.0 and rain.at(20.0) == 3.0 and rain.at(99.0) == 1.0
    assert rain.mean(5.0, 15.0) == pytest.approx((5 * 2.0 + 5 * (5.0 + 4.0) / 2) / 10.0, rel=1e-15)
    assert rain.mean(0.0, 40.0) == pytest.approx((20.0 + 20 * 3.0 + 10 * 1.0) / 40.0, rel=1e-15)
    with pytest.raises(ValueError, match="must not decrease"):
        History(np.array([1.0, 0.0]), np.array([1.0, 1.0]))


def test_rain_per_horizontal_length_falls_on_an_edges_horizontal_projection():
    xy = np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 4.0]])
    edges = np.array([[0, 1], [1, 2]])
    np.testing.assert_allclose(boundary_flux_weights_m(xy, edges, True), [1.5, 3.0, 1.5])
    np.testing.assert_allclose(boundary_flux_weights_m(xy, edges, False), [2.5, 4.0, 1.5])


def test_a_surface_ponds_under_heavy_rain_and_is_released_when_it_stops():
    """Rain at 5 K_s on a 5 m silt column: the surface is held at psi = 0 within the first hours while the soil
    takes less than the rain (the ponded infiltration falls towards K_s), and every surface particle is
    released once the rain stops; the balance closed at each step."""
    xy, solution = ponding_column()
    top = xy[:, 1] > 5.0 - 1e-9
    rain_in = solution.boundary_inflow_m2_s[:, 1] / (0.2 * 1e-6)  # in K_s over the column's width
    psi = solution.pressure_head_m(xy)
    hours = solution.times_s / HOUR_S
    ponded = (hours >= 2) & (hours <= 6)
    assert np.all(solution.node_held[ponded][:, top]) and np.all(np.abs(psi[ponded][:, top]) < 1e-12)
    assert np.all(rain_in[ponded] < 5.0) and np.all(np.diff(rain_in[ponded]) < 0.0) and rain_in[6] > 1.0
    assert not solution.node_held[hours >= 7][:, top].any() and np.all(psi[hours >= 7][:, top] < -0.1)
    assert np.all(rain_in[hours >= 7] == 0.0)
    _closed(solution)


def test_a_drawdown_leaves_more_water_in_a_less_permeable_bank():
    """The reservoir falls from 9 m to 3 m in 10 h (h = 0.5 m): the face above the level drains as a seepage face
    (held, water out); 14 h later the water table 5 m inside has fallen to 7 m in a bank of K_s = 1e-5 m/s but
    stays at 8.5 m at 1e-7 m/s (towards the rapid-drawdown limit: no time to drain); balances closed."""
    tables = {}
    for k in (1e-5, 1e-7):
        xy, solution = drawdown_bank(spacing_m=0.5, conductivity_m_s=k)
        x, y = xy[:, 0], xy[:, 1]
        face = (x < 1e-9) & (y > 3.0)
        assert solution.node_held[-1][face].any() and solution.boundary_inflow_m2_s[-1, 0] < 0.0
        psi = solution.pressure_head_m(xy)[-1]
        inside = np.abs(x - 5.0) < 1e-9
        tables[k] = y[inside][psi[inside] >= 0.0].max()
        _closed(solution)
    assert tables[1e-7] - tables[1e-5] >= 1.0 and tables[1e-7] < 9.0


def _sloped_bank_drawn_down(loading_efficiency: float, conductivity_m_s: float):
    """A 4 m bank at 2:1 (crest 4 m long), saturated to its crest, its reservoir falling from the crest to the toe
    in an hour, at h = 0.25 m: (particles, ground height above each, the solution at 1 h)."""
    polygon = np.array([[0.0, 0.0], [12.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    xy = particles_in_polygon(polygon, 0.25)
    elem = triangulate(xy, 0.25, 1.5).elem_nodes
    ground_m = surface_height_m(polygon, xy[:, 0])
    on_face = (xy[:, 0] > 4.0 - 1e-9) & (np.abs(xy[:, 1] - ground_m) < 1e-6)
    level = History(np.array([0.0, HOUR_S]), np.array([4.0, 0.0]))
    reservoir = ReservoirBoundary("reservoir", on_face, level, np.where(xy[:, 0] > 4.0, ground_m, np.inf),
                                  loading_efficiency)
    k = np.broadcast_to(conductivity_tensor(conductivity_m_s, conductivity_m_s, 0.0), (elem.shape[0], 2, 2))
    problem = TransientProblem(xy, elem, k, np.zeros(elem.shape[0], dtype=np.int64),
                               (VanGenuchten(0.05, 0.40, 0.5, 1.6, 1e-4),), (reservoir,), hydrostatic_head_m(xy, 4.0))
    return xy, ground_m, solve_transient_flow(problem, [HOUR_S])


def test_a_drawdown_unloads_the_pore_pressure_under_the_face_by_the_water_removed():
    """A bank that cannot drain in the hour (K_s = 1e-12 m/s): with loading efficiency 1 the pressure head under
    the uncovered face falls by the water removed above it, psi = y_s - y (the rapid-drawdown limit, B-bar = 1),
    the crest's stays hydrostatic from 4 m; with 0 the flow alone keeps the full reservoir's 4 - y inside.  At
    1e-6 m/s the water drains towards the face as well.  Balances closed."""
    for efficiency, expected in ((1.0, lambda y, ground: ground - y), (0.0, lambda y, ground: 4.0 - y)):
        xy, ground_m, solution = _sloped_bank_drawn_down(efficiency, 1e-12)
        x, y = xy[:, 0], xy[:, 1]
        psi = solution.pressure_head_m(xy)[-1]
        inside = ~solution.node_held[-1] & (y < ground_m - 0.3)  # off the seepage face's boundary layer
        under_face, under_crest = inside & (x > 4.5), inside & (x < 3.5)
        np.testing.assert_allclose(psi[under_face], expected(y, ground_m)[under_face], atol=1e-3)
        np.testing.assert_allclose(psi[under_crest], 4.0 - y[under_crest], atol=1e-3)
        if efficiency == 0.0:
            _closed(solution)
        else:  # nothing drains (4e-10 m2 leaves): the error against the unloading's own storage change, S_s A |dpsi|
            unloading_m2 = 1e-4 * 32.0 * float(np.mean(np.abs(psi - solution.pressure_head_m(xy)[0])))
            assert abs(solution.balance_error_m2[-1]) <= BALANCE * unloading_m2
    xy, ground_m, drained = _sloped_bank_drawn_down(1.0, 1e-6)
    y = xy[:, 1]
    under_face = ~drained.node_held[-1] & (xy[:, 0] > 4.5) & (y < ground_m - 0.3)
    assert np.all(drained.pressure_head_m(xy)[-1][under_face] < ground_m[under_face] - y[under_face] + 1e-3)
    _closed(drained)


@pytest.mark.parametrize("demand_ks", [0.01, 0.002], ids=["beyond what the soil lifts", "within it"])
def test_an_evaporating_surface_dries_to_its_limit_where_the_soil_cannot_supply_the_demand(demand_ks):
    """5 m of Gardner's soil (alpha 1 /m) over its water table, the surface's dry limit -6 m, h = 0.125 m, to steady
    state from hydrostatic water.  The most it lifts with its surface at -6 m is Gardner's (1958)
    E = K_s (e^(-alpha L) - e^(alpha psi_d)) / (1 - e^(-alpha L)) = 0.00429 K_s: a demand of 0.01 K_s holds the
    surface at -6 m and draws out E (within 1%: 0.54%, falling 4 times per halving of h, 8.5% at 0.5 m) along
    Gardner's profile for E (within 0.005 m); a demand of 0.002 K_s is met in full, the surface released above the
    limit.  Balances closed."""
    result = dry_limit_column(demand_ks * 1e-6, -6.0, spacing_m=0.125)
    limited = demand_ks * 1e-6 > result["limited_m_s"]
    assert limited == (demand_ks == 0.01) and result["held"] == limited
    assert result["computed_m_s"] == pytest.approx(result["evaporation_m_s"], rel=0.01 if limited else 1e-9)
    assert result["error_m"] < 0.005
    assert (result["top_psi_m"] == pytest.approx(-6.0, abs=1e-12)) if limited else result["top_psi_m"] > -6.0 + 0.1
    _closed(result["solution"])


def test_a_dried_surface_is_released_when_the_rain_returns():
    """The column held at its dry limit after a long evaporation (0.01 K_s, limit -6 m), then rain at 0.5 K_s: the
    surface leaves the limit at once and wets; the rain enters in full; the balance closed."""
    column = Column(1.0, (Layer(5.0, 1e-6, WATER_CONTENT_RANGE),), 0.0, 0.0)
    dry_s = 1e10
    flux = History(np.array([0.0, dry_s, dry_s]), np.array([-1e-8, -1e-8, 5e-7]))
    xy, problem = column_problem(column, 0.25, rain_m_s=flux, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0),
                                 dry_limit_m=-6.0)
    solution = solve_transient_flow(problem, [dry_s, dry_s + HOUR_S, dry_s + 6 * HOUR_S],
                                    TransientSettings(max_step_s=1e9))
    top = xy[:, 1] > 5.0 - 1e-9
    psi = solution.pressure_head_m(xy)[:, top].mean(axis=1)
    assert solution.node_held[1][top].all() and psi[1] == pytest.approx(-6.0, abs=1e-12)
    assert not solution.node_held[2:][:, top].any() and psi[2] > -6.0 and psi[3] > psi[2]
    assert solution.boundary_inflow_m2_s[-1, 1] == pytest.approx(5e-7 * 0.5, rel=1e-9)
    _closed(solution)


def test_a_dry_limit_must_be_a_suction_and_below_the_initial_state():
    column = Column(1.0, (Layer(5.0, 1e-6, WATER_CONTENT_RANGE),), 0.0, -1e-8)
    for limit, message in ((0.5, "dry_limit_m must be a finite pressure head below 0"),
                           (-3.0, "its initial pressure head is down to -5 m, below its dry limit -3 m")):
        _, problem = column_problem(column, 0.5, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0), dry_limit_m=limit)
        with pytest.raises(ValueError, match=message):
            solve_transient_flow(problem, [HOUR_S])


def test_a_step_that_cannot_converge_is_refused_with_the_time():
    xy, problem = column_problem(HOMOGENEOUS, 0.25)
    settings = TransientSettings(initial_step_s=3600.0, min_step_s=3000.0, max_step_s=3600.0, max_iterations=2,
                                 easy_iterations=1, hard_iterations=2)
    with pytest.raises(FlowNotConverged, match="does not converge at t = 0 s"):
        solve_transient_flow(problem, [HOUR_S], settings)


def test_a_rain_history_is_applied_in_full_whatever_the_steps():
    """20 mm/h for 2 h then 5 mm/h for 1 h on the column: 45 mm cross its top (per horizontal area), to 1e-12."""
    rain = History(np.array([0.0, 7200.0, 7200.0, 10800.0, 10800.0]),
                   np.array([20.0, 20.0, 5.0, 5.0, 0.0]) * 1e-3 / HOUR_S)
    column = Column(1.0, (Layer(5.0, 1e-5, 0.34),), 0.0, 0.0)
    xy, problem = column_problem(column, 0.25, rain_m_s=rain, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0, 2.0))
    solution = solve_transient_flow(problem, [4 * HOUR_S])
    assert solution.boundary_cumulative_inflow_m2[-1, 1] == pytest.approx(0.045 * 0.5, rel=1e-12)
    _closed(solution)


# --- convergence (slow) --------------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("column", [HOMOGENEOUS, TWO_LAYERS], ids=["homogeneous", "two layers"])
def test_second_order_in_the_spacing(column):
    """h = 0.5, 0.25, 0.125 m, steps of 2 s, t = 3 h: orders 1.96, 2.01 (homogeneous), 1.92, 1.96 (two layers)."""
    orders = observed_orders([run.error_m[0] for run in spacing_convergence(column)])
    assert all(1.8 < order < 2.2 for order in orders)


@pytest.mark.slow
@pytest.mark.parametrize("column", [HOMOGENEOUS, TWO_LAYERS], ids=["homogeneous", "two layers"])
def test_first_order_in_the_step(column):
    """h = 0.125 m, fixed steps of 1200 s down to 75 s: the change between successive steps halves with the step
    (backward Euler), orders within [0.8, 1.1]."""
    _, differences = step_convergence(column)
    orders = observed_orders(differences)
    assert all(0.8 < order < 1.1 for order in orders) and orders[-1] > orders[0]
