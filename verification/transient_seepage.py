"""Transient unsaturated seepage (``spfem_core.transient_seepage``) against closed forms, on the
particles' own clouds and meshes (``spfem_core.cloud``, ``spfem_core.mesh``).

    python -m verification.transient_seepage            # every table of docs/verification.md (about 40 s)
    python -m verification.transient_seepage --only profiles balance

1. **Srivastava & Yeh (1991)**: infiltration toward a water table through a column of Gardner's
   soil, homogeneous and two-layered, from the steady profile of a flux q0 to that of qA
   (``verification.srivastava_yeh``).  The column is two spacings wide (three particles a row),
   psi = 0 on its base (the water table), the flux on its top edge, no flow on its sides; it starts
   from the exact initial profile at its particles.  Pressure-head profiles at several times, and
   the observed order of convergence in the spacing h (a fixed small step) and in the step dt (a
   fixed spacing; against the closed form and between successive steps).
2. **Lu & Griffiths (2004)**: the steady profile under a constant infiltration or evaporation
   rate (the same closed form, the flux throughout), reached by the transient solve, and the
   suction stress sigma_s = S_e gamma_w psi (Lu & Likos 2006; ``spfem_core.suction_stress``) with
   van Genuchten's S_e at Gardner's alpha and n = 2 (a choice of this check); and evaporation beyond
   what the column lifts, its surface held at its dry limit, against Gardner's (1958) flux at that
   limit (:func:`dry_limit_column`).
3. **Mass balance** of every run: the water in less the water out against the change of the
   stored water, including a column whose surface ponds under rain (the switch to psi = 0 and
   back) and a bank whose reservoir is drawn down (the face above the level a seepage face).
4. **A slope under a day of rain** (:func:`slope_problem`), the benchmark's scene
   (``benchmarks/bench_transient_seepage.py``), against itself with short steps: the error of the
   default step control.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from spfem_core.cloud import particles_in_polygon
from spfem_core.flow_system import conductivity_tensor
from spfem_core.geometry import surface_height_m
from spfem_core.mesh import boundary_edges, triangulate
from spfem_core.soil_water import Gardner, VanGenuchten
from spfem_core.suction_stress import suction_stress_pa
from spfem_core.transient_seepage import (
    FluxBoundary,
    HeadBoundary,
    History,
    ReservoirBoundary,
    SeepageFace,
    TransientProblem,
    TransientSettings,
    TransientSolution,
    boundary_flux_weights_m,
    hydrostatic_head_m,
    solve_transient_flow,
)
from verification.srivastava_yeh import Column, Layer, SrivastavaYeh, steady_pressure_head_m

HOUR_S = 3600.0
RESIDUAL_WATER_CONTENT = 0.06
WATER_CONTENT_RANGE = 0.34  # theta_s - theta_r

HOMOGENEOUS = Column(1.0, (Layer(10.0, 1e-5, WATER_CONTENT_RANGE),), 0.1e-5, 0.9e-5)
"""A 10 m column of Gardner's soil, alpha = 1 /m, K_s = 1e-5 m/s (36 mm/h), theta 0.06-0.40, the flux
raised from 0.1 K_s to 0.9 K_s: its time scale dtheta / (alpha K_s) is 9.4 h."""
TWO_LAYERS = Column(1.0, (Layer(5.0, 1e-5, WATER_CONTENT_RANGE), Layer(5.0, 1e-4, WATER_CONTENT_RANGE)),
                    0.1e-5, 0.9e-5)
"""5 m of coarse soil (K_s = 1e-4 m/s) over 5 m of finer (1e-5 m/s) above the water table, the flux of
the homogeneous column: the ratio of Bandai & Ghezzehei's (2022) rendering of Srivastava & Yeh's
two-layer case (K_s 1 and 10 cm/h), against which this solution was checked to 1e-11."""
PROFILE_TIMES_S = np.array([1.0, 3.0, 6.0, 12.0, 24.0]) * HOUR_S
CONVERGENCE_TIME_S = 3.0 * HOUR_S


def column_problem(column: Column, spacing_m: float, rain_m_s: History | None = None, initial_head=None,
                   curves=None, width_spacings: int = 2, dry_limit_m: float | None = None):
    """(particles (n, 2), the transient problem) of ``column`` (module doc, item 1) at ``spacing_m``:
    Gardner's curve per layer (a triangle takes the layer of its centroid; the interfaces fall on
    rows of particles), psi = 0 at the base, the flux ``rain_m_s`` (default: qA from t = 0) per
    horizontal length on the top edge (evaporating, held at ``dry_limit_m`` where the soil cannot supply
    it), the initial heads ``initial_head(particles)`` (default: the steady profile of q0)."""
    height = column.height_m
    width = width_spacings * spacing_m
    xy = particles_in_polygon(np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]]), spacing_m)
    elem = triangulate(xy, spacing_m, 1.5).elem_nodes
    material = column.layer_of(xy[elem].mean(axis=1)[:, 1])
    if curves is None:
        curves = tuple(Gardner(RESIDUAL_WATER_CONTENT, RESIDUAL_WATER_CONTENT + layer.water_content_range,
                               column.alpha_1_m) for layer in column.layers)
    ks = np.array([layer.saturated_conductivity_m_s for layer in column.layers])[material]
    y = xy[:, 1]
    tol = 1e-9 * height
    edges = boundary_edges(elem)
    top = edges[(y[edges[:, 0]] > height - tol) & (y[edges[:, 1]] > height - tol)]
    rain = History.constant(column.flux_m_s) if rain_m_s is None else rain_m_s
    boundaries = (HeadBoundary("water_table", y < tol, History.constant(0.0), pressure=True),
                  FluxBoundary("surface", boundary_flux_weights_m(xy, top, True), rain, dry_limit_m=dry_limit_m))
    if initial_head is None:
        head = y + steady_pressure_head_m(column, y, column.initial_flux_m_s)
    else:
        head = initial_head(xy)
    return xy, TransientProblem(xy, elem, conductivity_tensor(ks, ks, 0.0), material, curves, boundaries, head)


def fixed_steps(step_s: float) -> TransientSettings:
    """Every step ``step_s`` long."""
    return TransientSettings(initial_step_s=step_s, min_step_s=step_s, max_step_s=step_s)


@dataclass
class ProfileRun:
    """A column's solve against the closed form at its saved times."""

    spacing_m: float
    particles: int
    error_m: np.ndarray  # (times,) the largest |psi - psi_exact| over the particles
    top_m: np.ndarray  # (times,) psi at the top, computed
    top_exact_m: np.ndarray
    solution: TransientSolution
    wall_s: float


def profile_run(column: Column, spacing_m: float, times_s, settings: TransientSettings = TransientSettings(),
                reference: SrivastavaYeh | None = None) -> ProfileRun:
    """Solve ``column`` at ``spacing_m`` and compare its pressure heads with Srivastava & Yeh's at ``times_s``."""
    times_s = np.asarray(times_s, dtype=float)
    reference = reference or SrivastavaYeh(column, float(times_s.min()))
    xy, problem = column_problem(column, spacing_m)
    start = time.perf_counter()
    solution = solve_transient_flow(problem, times_s, settings)
    wall = time.perf_counter() - start
    psi = solution.pressure_head_m(xy)[1:]
    exact = np.array([reference.pressure_head_m(xy[:, 1], t) for t in times_s])
    top = xy[:, 1] > column.height_m - 1e-9
    return ProfileRun(spacing_m, xy.shape[0], np.max(np.abs(psi - exact), axis=1), psi[:, top].mean(axis=1),
                      exact[:, top].mean(axis=1), solution, wall)


def observed_orders(errors) -> list[float]:
    """log2 of the ratio of successive errors (levels halving their parameter)."""
    e = np.asarray(errors, dtype=float)
    return [math.log2(a / b) if a > 0 and b > 0 else math.nan for a, b in zip(e[:-1], e[1:])]


def spacing_convergence(column: Column, spacings_m=(0.5, 0.25, 0.125), step_s: float = 2.0,
                        time_s: float = CONVERGENCE_TIME_S) -> list[ProfileRun]:
    """The column at each spacing with a fixed small step (the error of the step about 1e-4 m)."""
    reference = SrivastavaYeh(column, time_s)
    return [profile_run(column, h, [time_s], fixed_steps(step_s), reference) for h in spacings_m]


def step_convergence(column: Column, steps_s=(1200.0, 600.0, 300.0, 150.0, 75.0), spacing_m: float = 0.125,
                     time_s: float = CONVERGENCE_TIME_S) -> tuple[list[ProfileRun], list[float]]:
    """(the column with each fixed step at one spacing, the largest |psi_dt - psi_dt/2| of successive steps)."""
    reference = SrivastavaYeh(column, time_s)
    runs = [profile_run(column, spacing_m, [time_s], fixed_steps(dt), reference) for dt in steps_s]
    xy, _ = column_problem(column, spacing_m)
    psi = [run.solution.pressure_head_m(xy)[-1] for run in runs]
    return runs, [float(np.max(np.abs(a - b))) for a, b in zip(psi[:-1], psi[1:])]


LU_GRIFFITHS_N = 2.0
"""van Genuchten's n of the suction stress's S_e, at Gardner's alpha (a choice of this check)."""


def lu_griffiths(flux_m_s: float, spacing_m: float = 0.125, height_m: float = 5.0, alpha_1_m: float = 1.0,
                 conductivity_m_s: float = 1e-6) -> dict:
    """The steady column under a downward flux ``flux_m_s`` (negative: evaporation) reached by the transient
    solve from hydrostatic water, against the closed form; and the suction stress of both."""
    column = Column(alpha_1_m, (Layer(height_m, conductivity_m_s, WATER_CONTENT_RANGE),), flux_m_s, flux_m_s)
    xy, problem = column_problem(column, spacing_m, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0))
    settings = TransientSettings(initial_step_s=60.0, max_step_s=1e9)
    start = time.perf_counter()
    solution = solve_transient_flow(problem, [1e11], settings)
    wall = time.perf_counter() - start
    y = xy[:, 1]
    psi = solution.pressure_head_m(xy)[-1]
    exact = steady_pressure_head_m(column, y, flux_m_s)
    retention = VanGenuchten(RESIDUAL_WATER_CONTENT, RESIDUAL_WATER_CONTENT + WATER_CONTENT_RANGE, alpha_1_m,
                             LU_GRIFFITHS_N)
    stress = suction_stress_pa(retention, psi)
    stress_exact = suction_stress_pa(retention, exact)
    return {"flux_m_s": flux_m_s, "particles": xy.shape[0], "y_m": y, "psi_m": psi, "psi_exact_m": exact,
            "error_m": float(np.max(np.abs(psi - exact))), "stress_pa": stress, "stress_exact_pa": stress_exact,
            "stress_error_pa": float(np.max(np.abs(stress - stress_exact))), "solution": solution, "wall_s": wall}


def gardner_dry_limit_flux_m_s(height_m: float, alpha_1_m: float, conductivity_m_s: float,
                               dry_limit_m: float) -> float:
    """The steady upward flux (m/s, > 0) through a column of Gardner's soil ``height_m`` above its water table
    whose surface is held at psi_d = ``dry_limit_m``: from Gardner's (1958) steady profile
    exp(alpha psi) = (1 + E / K_s) exp(-alpha z) - E / K_s at z = L,
    E = K_s (exp(-alpha L) - exp(alpha psi_d)) / (1 - exp(-alpha L)) (none unless psi_d < -L)."""
    top = math.exp(-alpha_1_m * height_m)
    return conductivity_m_s * (top - math.exp(alpha_1_m * dry_limit_m)) / (1.0 - top)


def dry_limit_column(demand_m_s: float, dry_limit_m: float, spacing_m: float = 0.25, height_m: float = 5.0,
                     alpha_1_m: float = 1.0, conductivity_m_s: float = 1e-6) -> dict:
    """A column of Gardner's soil under the evaporation ``demand_m_s`` (> 0, up) with the surface's dry limit
    ``dry_limit_m``, from hydrostatic water to steady state: the surface held at the limit where the demand
    exceeds what the soil can lift (:func:`gardner_dry_limit_flux_m_s`), the flux then Gardner's and the
    profile his for that flux; else the demand's."""
    limited_m_s = gardner_dry_limit_flux_m_s(height_m, alpha_1_m, conductivity_m_s, dry_limit_m)
    evaporation_m_s = min(demand_m_s, limited_m_s)
    column = Column(alpha_1_m, (Layer(height_m, conductivity_m_s, WATER_CONTENT_RANGE),), 0.0, -demand_m_s)
    xy, problem = column_problem(column, spacing_m, initial_head=lambda xy: hydrostatic_head_m(xy, 0.0),
                                 dry_limit_m=dry_limit_m)
    solution = solve_transient_flow(problem, [1e11], TransientSettings(initial_step_s=60.0, max_step_s=1e9))
    y = xy[:, 1]
    psi = solution.pressure_head_m(xy)[-1]
    exact = steady_pressure_head_m(column, y, -evaporation_m_s)
    width_m = float(np.ptp(xy[:, 0]))
    surface = list(solution.boundary_names).index("surface")
    out_m_s = -float(solution.boundary_inflow_m2_s[-1, surface]) / width_m
    top = y > height_m - 1e-9
    return {"demand_m_s": demand_m_s, "limited_m_s": limited_m_s, "evaporation_m_s": evaporation_m_s,
            "computed_m_s": out_m_s, "top_psi_m": float(psi[top].mean()), "held": bool(solution.node_held[-1][top].all()),
            "error_m": float(np.max(np.abs(psi - exact))), "solution": solution, "particles": xy.shape[0]}


def ponding_column(spacing_m: float = 0.1, rain_m_s: float = 5e-6, rain_hours: float = 6.0, hours: float = 12.0):
    """A 5 m column of van Genuchten silt (alpha 1 /m, n 1.6, K_s 1e-6 m/s, S_s 1e-4 /m) at hydrostatic
    suction (capped at 3 m) above a water table at its base, rained on at 5 K_s for ``rain_hours``: its
    surface ponds within the hour and is released when the rain stops."""
    column = Column(1.0, (Layer(5.0, 1e-6, 0.35),), 0.0, 0.0)
    curve = VanGenuchten(0.05, 0.40, 1.0, 1.6, 1e-4)
    rain = History(np.array([0.0, rain_hours * HOUR_S, rain_hours * HOUR_S]), np.array([rain_m_s, rain_m_s, 0.0]))
    xy, problem = column_problem(column, spacing_m, rain_m_s=rain, curves=(curve,),
                                 initial_head=lambda xy: hydrostatic_head_m(xy, 0.0, 3.0))
    solution = solve_transient_flow(problem, np.arange(1.0, hours + 0.5) * HOUR_S)
    return xy, solution


def drawdown_bank(spacing_m: float = 0.25, conductivity_m_s: float = 1e-5, drawdown_hours: float = 10.0,
                  hours: float = 24.0):
    """A bank 10 m high, 20 m long (its upstream face vertical at x = 0) of van Genuchten soil (alpha 2 /m,
    n 2, S_s 1e-4 /m): the reservoir against the face falls from 9 m to 3 m over ``drawdown_hours``, a
    total head of 9 m holds at the far end below that level; the face above the reservoir is a seepage face."""
    polygon = np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 10.0], [0.0, 10.0]])
    xy = particles_in_polygon(polygon, spacing_m)
    elem = triangulate(xy, spacing_m, 1.5).elem_nodes
    x, y = xy[:, 0], xy[:, 1]
    tol = 1e-9 * 20.0
    level = History(np.array([0.0, drawdown_hours * HOUR_S]), np.array([9.0, 3.0]))
    boundaries = (ReservoirBoundary("reservoir", x < tol, level),
                  HeadBoundary("far_field", (x > 20.0 - tol) & (y <= 9.0 + tol), History.constant(9.0)))
    curve = VanGenuchten(0.05, 0.40, 2.0, 2.0, 1e-4)
    k = np.broadcast_to(conductivity_tensor(conductivity_m_s, conductivity_m_s, 0.0), (elem.shape[0], 2, 2))
    problem = TransientProblem(xy, elem, k, np.zeros(elem.shape[0], dtype=np.int64), (curve,), boundaries,
                               hydrostatic_head_m(xy, 9.0))
    return xy, solve_transient_flow(problem, np.arange(1.0, hours + 0.5) * HOUR_S)


SLOPE_POLYGON_M = np.array([[0.0, 0.0], [60.0, 0.0], [60.0, 20.0], [40.0, 20.0], [20.0, 10.0], [0.0, 10.0]])
"""A 10 m slope at 1:2 between a 10 m toe bench and a 20 m crest, 60 m long."""


def slope_problem(spacing_m: float, rain_mm_h: float = 20.0, rain_hours: float = 24.0):
    """(particles, problem) of the slope of :data:`SLOPE_POLYGON_M` in van Genuchten silty sand (alpha 2 /m,
    n 1.8, K_s 1e-5 m/s horizontally, half that vertically, S_s 1e-4 /m), its water table from 8 m under
    the toe to 15 m under the crest (hydrostatic below, suction capped at 5 m above), held by total heads
    of 8 m and 15 m on the two sides below those levels, a seepage face on the toe's side above, rain of
    ``rain_mm_h`` per horizontal area on the ground (which ponds where it saturates) for ``rain_hours``."""
    xy = particles_in_polygon(SLOPE_POLYGON_M, spacing_m)
    elem = triangulate(xy, spacing_m, 1.5).elem_nodes
    x, y = xy[:, 0], xy[:, 1]
    tol = 1e-6 * 60.0
    edges = boundary_edges(elem)
    on_ground = np.abs(y - surface_height_m(SLOPE_POLYGON_M, x)) < tol
    ground = edges[on_ground[edges[:, 0]] & on_ground[edges[:, 1]]]
    rain_m_s = rain_mm_h * 1e-3 / HOUR_S
    rain = History(np.array([0.0, rain_hours * HOUR_S, rain_hours * HOUR_S]), np.array([rain_m_s, rain_m_s, 0.0]))
    boundaries = (FluxBoundary("rain", boundary_flux_weights_m(xy, ground, True), rain),
                  HeadBoundary("toe_side", (x < tol) & (y <= 8.0 + tol), History.constant(8.0)),
                  HeadBoundary("crest_side", (x > 60.0 - tol) & (y <= 15.0 + tol), History.constant(15.0)),
                  SeepageFace("toe_face", (x < tol) & (y > 8.0 + tol)))
    curve = VanGenuchten(0.05, 0.40, 2.0, 1.8, 1e-4)
    k = np.broadcast_to(conductivity_tensor(1e-5, 0.5e-5, 0.0), (elem.shape[0], 2, 2))
    water_table = 8.0 + 7.0 * x / 60.0
    problem = TransientProblem(xy, elem, k, np.zeros(elem.shape[0], dtype=np.int64), (curve,), boundaries,
                               hydrostatic_head_m(xy, water_table, 5.0))
    return xy, problem


def balance_row(label: str, solution: TransientSolution) -> str:
    """A row of the mass-balance table: in, out, stored, the cumulative closure, the worst step's."""
    stored = solution.stored_water_m2[-1] - solution.stored_water_m2[0]
    return (f"| {label} | {solution.step_s.size} | {solution.water_in_m2[-1]:.6g} | {solution.water_out_m2[-1]:.6g} | "
            f"{stored:.6g} | {solution.balance_fraction()[-1]:.1e} | {solution.step_balance_fractions().max():.1e} |")


def print_profiles(runs: dict) -> None:
    print("Srivastava & Yeh (1991): psi at the top and the largest |psi - psi_exact| over the column (m)\n")
    print("| column | h (m) | particles | steps | t (h) | psi top, exact | psi top | largest error | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, run in runs.items():
        for k, t in enumerate(PROFILE_TIMES_S):
            print(f"| {label} | {run.spacing_m:g} | {run.particles} | {run.solution.step_s.size} | {t / HOUR_S:g} | "
                  f"{run.top_exact_m[k]:.4f} | {run.top_m[k]:.4f} | {run.error_m[k]:.4f} | {run.wall_s:.2f} |")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=["profiles", "spacing", "step", "steady", "dry", "balance",
                                                      "slope"])
    args = parser.parse_args(argv)
    todo = set(args.only or ["profiles", "spacing", "step", "steady", "dry", "balance", "slope"])
    balance = []

    if todo & {"profiles", "balance"}:
        runs = {}
        for name, column in (("homogeneous", HOMOGENEOUS), ("two layers", TWO_LAYERS)):
            reference = SrivastavaYeh(column, PROFILE_TIMES_S[0])
            runs[f"{name}, default steps"] = profile_run(column, 0.125, PROFILE_TIMES_S, reference=reference)
            runs[f"{name}, steps <= 300 s"] = profile_run(column, 0.125, PROFILE_TIMES_S,
                                                          TransientSettings(max_step_s=300.0), reference)
        if "profiles" in todo:
            print_profiles(runs)
        balance += [(f"Srivastava & Yeh, {label}", run.solution) for label, run in runs.items()]

    if "spacing" in todo:
        print(f"\nOrder in h: the largest |psi - psi_exact| at t = {CONVERGENCE_TIME_S / HOUR_S:g} h, steps of 2 s\n")
        print("| column | h (m) | particles | error (m) | order |")
        print("|---|---|---|---|---|")
        for name, column in (("homogeneous", HOMOGENEOUS), ("two layers", TWO_LAYERS)):
            runs_h = spacing_convergence(column)
            orders = [math.nan] + observed_orders([r.error_m[0] for r in runs_h])
            for run, order in zip(runs_h, orders):
                print(f"| {name} | {run.spacing_m:g} | {run.particles} | {run.error_m[0]:.3e} | {order:.2f} |")
            balance += [(f"order in h, {name}, h = {r.spacing_m:g} m", r.solution) for r in runs_h]

    if "step" in todo:
        print(f"\nOrder in dt: h = 0.125 m, t = {CONVERGENCE_TIME_S / HOUR_S:g} h, fixed steps\n")
        print("| column | dt (s) | error (m) | order | max abs(psi_dt - psi_dt/2) (m) | order |")
        print("|---|---|---|---|---|---|")
        for name, column in (("homogeneous", HOMOGENEOUS), ("two layers", TWO_LAYERS)):
            runs_dt, differences = step_convergence(column)
            orders = [math.nan] + observed_orders([r.error_m[0] for r in runs_dt])
            difference_orders = [math.nan] + observed_orders(differences) + [math.nan]
            differences = differences + [math.nan]
            for run, order, difference, d_order in zip(runs_dt, orders, differences, difference_orders):
                dt = run.solution.step_s[0]
                print(f"| {name} | {dt:g} | {run.error_m[0]:.3e} | {order:.2f} | {difference:.3e} | {d_order:.2f} |")
            balance += [(f"order in dt, {name}, dt = {r.solution.step_s[0]:g} s", r.solution) for r in runs_dt]

    if "steady" in todo:
        print("\nLu & Griffiths (2004): steady infiltration and evaporation, 5 m above the water table, h = 0.125 m, "
              "K_s = 1e-6 m/s, alpha = 1 /m (suction stress with van Genuchten's S_e, n = 2)\n")
        print("| flux (K_s) | particles | steps | psi top, exact (m) | largest psi error (m) | sigma_s top, exact (kPa) "
              "| largest sigma_s error (kPa) |")
        print("|---|---|---|---|---|---|---|")
        for ratio in (0.5, 0.1, -0.005):
            r = lu_griffiths(ratio * 1e-6)
            top = r["y_m"] > 5.0 - 1e-9
            print(f"| {ratio:+g} | {r['particles']} | {r['solution'].step_s.size} | {r['psi_exact_m'][top].mean():.4f} | "
                  f"{r['error_m']:.2e} | {r['stress_exact_pa'][top].mean() / 1e3:.3f} | {r['stress_error_pa'] / 1e3:.2e} |")
            balance.append((f"Lu & Griffiths, flux {ratio:+g} K_s", r["solution"]))

    if "dry" in todo:
        print("\nEvaporation beyond what the soil lifts: the same column, demand 0.01 K_s, surface dry limit -6 m; "
              f"Gardner's flux at the limit {gardner_dry_limit_flux_m_s(5.0, 1.0, 1e-6, -6.0) / 1e-6:.5f} K_s\n")
        print("| h (m) | particles | surface held | psi top (m) | flux out (K_s) | its error | order | "
              "largest psi error (m) |")
        print("|---|---|---|---|---|---|---|---|")
        errors = []
        for spacing in (0.5, 0.25, 0.125, 0.0625):
            r = dry_limit_column(1e-8, -6.0, spacing_m=spacing)
            errors.append(r["computed_m_s"] / r["evaporation_m_s"] - 1.0)
            order = observed_orders(errors[-2:])[0] if len(errors) > 1 else math.nan
            print(f"| {spacing:g} | {r['particles']} | {r['held']} | {r['top_psi_m']:.4f} | {r['computed_m_s'] / 1e-6:.5f} "
                  f"| {errors[-1]:.2e} | {order:.2f} | {r['error_m']:.2e} |")
            balance.append((f"evaporation to the dry limit, h = {spacing:g} m", r["solution"]))
        within = dry_limit_column(2e-9, -6.0, spacing_m=0.125)
        print(f"\nA demand of 0.002 K_s (within what the soil lifts): surface held {within['held']}, psi at the top "
              f"{within['top_psi_m']:.4f} m, flux out {within['computed_m_s'] / 1e-6:.6f} K_s, largest psi error "
              f"{within['error_m']:.2e} m")
        balance.append(("evaporation within what the soil lifts", within["solution"]))

    if "balance" in todo:
        _, ponded = ponding_column()
        balance.append(("ponding column (rain 5 K_s for 6 h, 12 h)", ponded))
        for k in (1e-5, 1e-7):
            _, drawn = drawdown_bank(conductivity_m_s=k)
            balance.append((f"drawdown 9 m to 3 m in 10 h, K_s = {k:g} m/s (24 h)", drawn))
        print("\nMass balance (m2 per metre): in, out, stored change; closure = abs(in - out - stored) / "
              "max(in, out, abs(stored)); the worst step's over its own balance\n")
        print("| run | steps | in | out | stored | closure | worst step |")
        print("|---|---|---|---|---|---|---|")
        for label, solution in balance:
            print(balance_row(label, solution))

    if "slope" in todo:
        xy, problem = slope_problem(1.15)
        out = np.array([6.0, 12.0, 24.0]) * HOUR_S
        runs_s = {}
        for label, settings in (("default", TransientSettings()), ("steps <= 600 s", TransientSettings(max_step_s=600.0)),
                                ("steps <= 30 s", TransientSettings(max_step_s=30.0))):
            runs_s[label] = solve_transient_flow(problem, out, settings)
        reference = runs_s["steps <= 30 s"].pressure_head_m(xy)
        print(f"\nThe slope under 20 mm/h ({xy.shape[0]} particles): largest |psi - psi(steps <= 30 s)| (m) and the "
              "rain taken in (m2/m)\n")
        print("| steps | count | 6 h | 12 h | 24 h | rain in at 24 h | closure |")
        print("|---|---|---|---|---|---|---|")
        for label, solution in runs_s.items():
            d = np.max(np.abs(solution.pressure_head_m(xy) - reference), axis=1)
            print(f"| {label} | {solution.step_s.size} | {d[1]:.4f} | {d[2]:.4f} | {d[3]:.4f} | "
                  f"{solution.boundary_cumulative_inflow_m2[-1, 0]:.4f} | {solution.balance_fraction()[-1]:.1e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
