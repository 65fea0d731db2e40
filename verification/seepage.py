"""Steady seepage against closed forms and exact solutions: confined flow, the rectangular dam.

    python -m verification.seepage          # the tables of docs/verification.md, "Steady seepage"
    python -m verification.seepage --dam    # the dam's FOS: its flow, a drawn line, the published values
    python -m verification.seepage --dam-convergence 0.5 0.25 0.125   # the dam's FOS against h, wet and dry

1. **Radial flow in a quarter annulus** (confined; no-flow on the two radii, heads h1 on r1 and
   h2 on r2, both above the domain: it is saturated): h = h1 + (h2 - h1) ln(r / r1) / ln(r2 / r1), the discharge
   q = (pi / 2) k (h2 - h1) / ln(r2 / r1), against the spacing (the arcs are polygons with a
   vertex about every spacing, their chords' sagitta h^2 / 8r).
2. **Flow under a sheet pile** in a layer of thickness T, penetration s, head loss H (Pavlovsky;
   Harr 1962): q / (k H) = K(lambda') / (2 K(lambda)), lambda = sin(pi s / 2T), lambda' =
   cos(pi s / 2T), K the complete elliptic integral of modulus lambda (scipy's ``ellipk`` takes its
   square).  The antisymmetric half is solved: the downstream half-layer, h = H / 2 on the plane of
   the pile below its tip, h = 0 on the downstream ground, no flow on the pile and the base, the
   layer 4T long (the far end no-flow).
3. **The rectangular dam** (length L, upstream water H1, tailwater H2, impermeable base): the
   discharge is Dupuit's q = k (H1^2 - H2^2) / (2L), exact for this problem (Charny's proof),
   though the free surface is not Dupuit's parabola; the exit point and the free surface against
   Polubarinova-Kochina's exact solution (:data:`PK_FREE_SURFACE`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

K_M_S = 1e-5

PK_EXIT_Y_M = 3.9396
PK_FREE_SURFACE = ((2.0, 9.394), (5.0, 8.026), (8.0, 6.092), (9.0, 5.220), (9.5, 4.685), (9.9, 4.139))
"""Polubarinova-Kochina's exact solution of the rectangular dam H1 = 10 m, H2 = 2 m, L = 10 m: the
exit point (m) and (x, y) of the free surface (m).  Evaluated with the implementation of Shadab,
Hiatt & Hesse (github.com/mashadab/Polubarinova-Kochina-solutions, validated there against Hornung &
Krueger 1985) and checked against a finite-difference solution of Baiocchi's variational
inequality at 0.1 m (the same to its resolution): computed values, not read from a table."""


def _base_study(polygon, spacing_m: float, boundary: str, extra: str = "") -> str:
    points = ", ".join(f"[{x!r}, {y!r}]" for x, y in polygon)
    return f"""[study]
name = "seepage_check"
[geometry]
polygon_m = [{points}]
spacing_m = {spacing_m!r}
[[materials]]
name = "soil"
model = "elastic"
density_kg_m3 = 2000.0
youngs_modulus_pa = 1e8
poisson_ratio = 0.3
permeability_m_s = {K_M_S!r}
[[boundary]]
name = "base"
y_max_m = {min(y for _, y in polygon)!r}
vx_m_s = 0.0
vy_m_s = 0.0
[[stages]]
name = "gravity"
kind = "relaxation"
max_duration_s = 1.0
record_interval_s = 0.1
[seepage]
{extra}
{boundary}
"""


def rectangular_dam_text(spacing_m: float, h1_m: float = 10.0, h2_m: float = 2.0, length_m: float = 10.0,
                         height_m: float = 12.0, band_m: float = 0.0) -> str:
    """The rectangular dam as a study: upstream head h1, tailwater h2, a seepage face above it (and a
    transition band of ``band_m`` above the water table)."""
    boundary = f"""[[seepage.boundary]]
name = "upstream"
condition = "total_head"
x_max_m = 0.0
y_max_m = {h1_m!r}
total_head_m = {h1_m!r}
[[seepage.boundary]]
name = "face"
condition = "seepage_face"
x_min_m = {length_m!r}
[[seepage.boundary]]
name = "tailwater"
condition = "total_head"
x_min_m = {length_m!r}
y_max_m = {h2_m!r}
total_head_m = {h2_m!r}
"""
    return _base_study([(0.0, 0.0), (length_m, 0.0), (length_m, height_m), (0.0, height_m)], spacing_m, boundary,
                       f"unsaturated_band_m = {band_m!r}" if band_m else "")


def sheet_pile_text(spacing_m: float, thickness_m: float, penetration_m: float, head_loss_m: float) -> str:
    """The downstream half of the sheet-pile problem (module doc, item 2)."""
    t = thickness_m
    boundary = f"""[[seepage.boundary]]
name = "below_tip"
condition = "total_head"
x_max_m = 0.0
y_max_m = {-penetration_m!r}
total_head_m = {0.5 * head_loss_m!r}
[[seepage.boundary]]
name = "downstream"
condition = "total_head"
y_min_m = 0.0
total_head_m = 0.0
"""
    return _base_study([(0.0, -t), (4.0 * t, -t), (4.0 * t, 0.0), (0.0, 0.0)], spacing_m, boundary)


def sheet_pile_exact(thickness_m: float, penetration_m: float) -> float:
    """q / (k H) of the full problem (module doc, item 2)."""
    from scipy.special import ellipk

    angle = math.pi * penetration_m / (2.0 * thickness_m)
    return float(ellipk(math.cos(angle) ** 2) / (2.0 * ellipk(math.sin(angle) ** 2)))


def quarter_annulus(spacing_m: float, r1_m: float = 2.0, r2_m: float = 10.0, h1_m: float = 100.0,
                    h2_m: float = 110.0) -> tuple[float, float, float]:
    """(discharge / closed form - 1, the largest head error over h2 - h1, particles) of the radial flow
    (module doc, item 1), solved by ``spfem_core.seepage`` on the study's kind of cloud and mesh."""
    from spfem_core.cloud import particles_in_polygon
    from spfem_core.mesh import triangulate
    from spfem_core.seepage import FlowProblem, conductivity_tensor, solve_steady_flow

    def arc(radius_m):  # a vertex about every spacing: every vertex is a particle
        angles = np.linspace(0.0, 0.5 * math.pi, max(2, math.ceil(0.5 * math.pi * radius_m / spacing_m)) + 1)
        return np.column_stack([radius_m * np.cos(angles), radius_m * np.sin(angles)])

    outer, inner = arc(r2_m), arc(r1_m)[::-1]
    xy = particles_in_polygon(np.vstack([outer, inner]), spacing_m)
    elem = triangulate(xy, spacing_m, 1.5).elem_nodes
    r = np.hypot(xy[:, 0], xy[:, 1])
    tol = 1e-3 * spacing_m + spacing_m**2 / (8.0 * r1_m)  # and the sagitta of the arcs' chords
    fixed = np.full(xy.shape[0], np.nan)
    fixed[r <= r1_m + tol] = h1_m
    fixed[r >= r2_m - tol] = h2_m
    k = np.broadcast_to(conductivity_tensor(K_M_S, K_M_S, 0.0), (elem.shape[0], 2, 2))
    problem = FlowProblem(xy, elem, k, fixed, np.zeros(xy.shape[0]), np.zeros(xy.shape[0], dtype=bool))
    solution = solve_steady_flow(problem)
    exact_q = 0.5 * math.pi * K_M_S * (h2_m - h1_m) / math.log(r2_m / r1_m)
    q = solution.node_inflow_m2_s[r >= r2_m - tol].sum()
    exact_h = h1_m + (h2_m - h1_m) * np.log(r / r1_m) / math.log(r2_m / r1_m)
    return q / exact_q - 1.0, float(np.max(np.abs(solution.head_m - exact_h)) / (h2_m - h1_m)), xy.shape[0]


def flow_of(text: str):
    """The ``StudyFlow`` of a study text."""
    from workflows.seepage.flow import study_flow
    from workflows.study import parse_study

    return study_flow(parse_study(text))


def rectangular_dam(spacing_m: float, band_m: float = 0.0) -> dict:
    """The rectangular dam at ``spacing_m``: discharge over Dupuit's, exit point, free surface at the
    abscissae of :data:`PK_FREE_SURFACE`, iterations."""
    from spfem_core.seepage import phreatic_segments
    from workflows.seepage.results import exit_point_m

    flow = flow_of(rectangular_dam_text(spacing_m, band_m=band_m))
    inflow = dict(zip(flow.conditions, flow.condition_inflow_m2_s()))
    dupuit = K_M_S * (10.0**2 - 2.0**2) / (2.0 * 10.0)
    segments = phreatic_segments(flow.node_xy_m, flow.elem_nodes, flow.solution.pressure_head_m(flow.node_xy_m))
    surface = []
    for x, _ in PK_FREE_SURFACE:  # the highest crossing of the vertical x
        heights = [a[1] + (x - a[0]) / (b[0] - a[0]) * (b[1] - a[1]) for a, b in segments
                   if min(a[0], b[0]) <= x <= max(a[0], b[0]) and a[0] != b[0]]
        surface.append(max(heights) if heights else math.nan)
    return {"inflow_ratio": inflow["upstream"] / dupuit,
            "outflow_ratio": -(inflow["face"] + inflow["tailwater"]) / dupuit,
            "exit_y_m": exit_point_m(flow)[1], "surface_m": surface, "iterations": flow.solution.iterations,
            "particles": flow.node_xy_m.shape[0], "wall_s": flow.wall_time_s}


DAM_STUDY = Path(__file__).resolve().parents[1] / "studies" / "seepage_dam.toml"
DAM_PUBLISHED = (("SLOPE/W, Morgenstern-Price (SEEP/W pore pressures)", 1.091), ("SLOPE/W, Bishop", 1.092),
                 ("Smith, Elements of Soil Mechanics ex. 5.12, Bishop", 1.07))
"""The published FOS of ``studies/seepage_dam.toml`` (GeoStudio Slope Stability Verification Manual,
section 2.46, as transcribed in github.com/njones61/xslope, benchmarks/geostudio/build_gs2_46.py)."""
LINE_POINTS = 200


def phreatic_line_through(study, flow) -> list[tuple[float, float]]:
    """A piezometric line through a flow's phreatic surface, spanning the domain: the highest crossing of
    the surface at each of ``LINE_POINTS`` abscissae; the ground where the surface has left it (below the
    exit point, the seepage face), the pond's level beyond where the surface meets the pond."""
    from spfem_core.geometry import surface_height_m
    from spfem_core.seepage import phreatic_segments

    polygon = np.array(study.geometry.polygon_m)
    segments = phreatic_segments(flow.node_xy_m, flow.elem_nodes, flow.solution.pressure_head_m(flow.node_xy_m))
    xs = np.linspace(polygon[:, 0].min(), polygon[:, 0].max(), LINE_POINTS)
    ground = surface_height_m(polygon, xs)
    pond = study.water.pond_level_m if study.water is not None else None
    line = []
    for x, top in zip(xs, ground):
        heights = [a[1] + (x - a[0]) / (b[0] - a[0]) * (b[1] - a[1]) for a, b in segments
                   if min(a[0], b[0]) <= x <= max(a[0], b[0]) and a[0] != b[0]]
        if heights:
            y = max(heights)
        elif pond is not None and top <= pond and x > study.water.pond_x_range_m[0]:
            y = pond
        else:
            y = top
        line.append((float(x), float(y)))
    return line


def dam_line_text(text: str, line) -> str:
    """The dam study with ``[seepage]`` replaced by a piezometric line (its pond kept)."""
    points = ", ".join(f"[{x:.4f}, {y:.4f}]" for x, y in line)
    start = text.index("[seepage]")
    end = text.index("[[boundary]]", start)
    text = text[:start] + text[end:]
    return text.replace("[water]\n", f"[water]\nphreatic_line_m = [{points}]\n", 1).replace(
        'name = "seepage_dam"', 'name = "seepage_dam_line"')


def dam_comparison(spacing_m: float | None, workers: int) -> None:
    """The dam's FOS on its computed flow and on a piezometric line through its phreatic surface."""
    import re
    import tempfile

    from workflows.cases import RunOptions
    from workflows.study import parse_study
    from workflows.study_types import run_study

    text = DAM_STUDY.read_text()
    if spacing_m is not None:
        text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)
    study = parse_study(text)
    flow = flow_of(text)
    line_text = dam_line_text(text, phreatic_line_through(study, flow))
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for label, each in (("computed flow ([seepage])", text), ("piezometric line through its phreatic surface",
                                                                   line_text)):
            outcome = run_study(parse_study(each), Path(scratch) / label[:8], RunOptions(workers=workers))
            rows.append((label, outcome.fos, outcome.fos_low, outcome.fos_high, outcome.timings_s["total"]))
    print(f"\nThe dam of studies/seepage_dam.toml at h = {study.geometry.spacing_m:g} m "
          f"({flow.node_xy_m.shape[0]} particles; the flow solved in {flow.wall_time_s:.2f} s, "
          f"{flow.solution.iterations} iterations)\n")
    print("| pore pressure | FOS [bracket] | wall (s) |")
    print("|---|---|---|")
    for label, fos, low, high, wall in rows:
        print(f"| {label} | {fos:.4f} [{low:.4f}, {high:.4f}] | {wall:.1f} |")
    for label, value in DAM_PUBLISHED:
        print(f"| published: {label} | {value:g} ({rows[0][1] / value - 1:+.1%}) | |")


def dam_convergence(spacings_m, workers: int) -> None:
    """The dam's FOS against the spacing, with its flow and without water (the same dam dry)."""
    import re
    import tempfile

    from workflows.cases import RunOptions
    from workflows.study import parse_study
    from workflows.study_types import run_study

    text = DAM_STUDY.read_text()
    dry = text[:text.index("[water]")] + text[text.index("[[boundary]]"):]
    print("| h (m) | FOS with the flow | FOS dry |\n|---|---|---|")
    for h in spacings_m:
        row = []
        for each in (text, dry):
            each = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {h:g}", each, count=1)
            with tempfile.TemporaryDirectory() as scratch:
                outcome = run_study(parse_study(each), Path(scratch), RunOptions(workers=workers))
            row.append(f"{outcome.fos:.4f} [{outcome.fos_low:.4f}, {outcome.fos_high:.4f}]")
        print(f"| {h:g} | {row[0]} | {row[1]} |", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacings", type=float, nargs="+", default=[0.5, 0.25, 0.125])
    parser.add_argument("--dam", action="store_true", help="only the dam's FOS on its flow and on a line")
    parser.add_argument("--dam-spacing", type=float, default=None, help="the dam's spacing (m), default the study's")
    parser.add_argument("--dam-convergence", type=float, nargs="+", metavar="H",
                        help="only the dam's FOS at these spacings (m), with its flow and dry")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    if args.dam:
        dam_comparison(args.dam_spacing, args.workers)
        return 0
    if args.dam_convergence:
        dam_convergence(args.dam_convergence, args.workers)
        return 0

    print("Radial flow, quarter annulus r 2-10 m (closed form)\n")
    print("| h (m) | particles | discharge error | largest head error / (h2 - h1) |")
    print("|---|---|---|---|")
    for h in args.spacings:
        q_error, h_error, n = quarter_annulus(h)
        print(f"| {h:g} | {n} | {q_error:+.2e} | {h_error:.2e} |")

    print("\nSheet pile, layer T = 10 m, head loss H = 10 m (Pavlovsky's closed form)\n")
    print("| s / T | h (m) | particles | q / (k H) | exact | error |")
    print("|---|---|---|---|---|---|")
    for ratio in (0.25, 0.5, 0.75):
        exact = sheet_pile_exact(10.0, 10.0 * ratio)
        for h in args.spacings:
            flow = flow_of(sheet_pile_text(h, 10.0, 10.0 * ratio, 10.0))
            q = dict(zip(flow.conditions, flow.condition_inflow_m2_s()))["below_tip"] / (K_M_S * 10.0)
            print(f"| {ratio:g} | {h:g} | {flow.node_xy_m.shape[0]} | {q:.5f} | {exact:.5f} | {q / exact - 1:+.2%} |")

    print("\nRectangular dam H1 = 10 m, H2 = 2 m, L = 10 m (Dupuit's discharge exact; Polubarinova-Kochina)\n")
    xs = " | ".join(f"y at x = {x:g}" for x, _ in PK_FREE_SURFACE)
    print(f"| h (m) | particles | iterations | inflow / Dupuit | outflow / Dupuit | exit y (m) | {xs} | wall (s) |")
    print("|---" * (7 + len(PK_FREE_SURFACE)) + "|")
    print(f"| exact | | | 1 | 1 | {PK_EXIT_Y_M:g} | " + " | ".join(f"{y:g}" for _, y in PK_FREE_SURFACE) + " | |")
    for h, band in [(h, 0.0) for h in args.spacings] + [(args.spacings[1], 0.5)]:
        r = rectangular_dam(h, band)
        label = f"{h:g}" + (f", band {band:g} m" if band else "")
        print(f"| {label} | {r['particles']} | {r['iterations']} | {r['inflow_ratio']:.5f} | {r['outflow_ratio']:.5f} | "
              f"{r['exit_y_m']:.3f} | " + " | ".join(f"{y:.3f}" for y in r["surface_m"]) + f" | {r['wall_s']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
