"""Where the one-thread step's cost per particle grows from 1k to 100k particles: each pass alone.

    python -m benchmarks.step_passes                      # the beam at 1k and 100k, every variant
    python -m benchmarks.step_passes --sizes 1k 10k 100k --repeats 5

The elastic cantilever beam of ``bench_core`` (beta = 0.1), on one thread, in a fresh process
per measurement (warm numba cache).  Each pass of the step (``spfem_core.stepper``: smoothing,
stress update, element forces, bond forces, leapfrog) runs alone in a compiled loop of many
repetitions on the beam's state after 20 steps; the best of 3 timings is quoted in ns per
particle and pass.  Three layouts of the same arithmetic are measured against the shipped one
(particles in Morton order, 512-item coloured blocks from 5,000 particles):

- ``one block``: the elements and bonds in one block (no colouring; what a one-thread run could
  do, at the price of sums in another order than on two threads);
- ``hilbert``: the particles in Hilbert-curve order instead of Morton order;
- ``packed bonds``: the bond pass reading one packed record per particle (x, y, v, L, E A; 9
  doubles written by a pass before it) instead of five arrays.

The figures say which pass grows and whether a layout cures it; the variants are not shipped.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from benchmarks.bench_core import BEAM

ROOT = Path(__file__).resolve().parents[1]
SIZES = {"1k": 1_000, "10k": 10_000, "100k": 100_000}
VARIANTS = ("shipped", "one block", "hilbert", "packed bonds")
PASSES = ("smoothing", "stress", "elements", "bonds", "leapfrog")

MEASURE = BEAM + r'''
import json, math, sys, time
import numpy as np
import spfem_core.cloud as cloud
import spfem_core.mesh as mesh_module
from numba import njit
from spfem_core.constitutive import update_stress
from spfem_core.integration import leapfrog
from spfem_core.nodal_force import add_bond_forces, add_element_forces
from spfem_core.smoothing import smooth_velocity_gradient

variant, n_target = {variant!r}, {n}


def hilbert_order(node_xy_m, h):
    """Permutation sorting the particles by the Hilbert index of their h-sized cell (ties by y, x)."""
    cell = np.floor((node_xy_m - node_xy_m.min(axis=0)) / h).astype(np.int64)
    side = 1
    while side <= cell.max():
        side *= 2
    x, y, index = cell[:, 0].copy(), cell[:, 1].copy(), np.zeros(len(cell), dtype=np.int64)
    s = side // 2
    while s > 0:
        rx, ry = (x & s) > 0, (y & s) > 0
        index += s * s * ((3 * rx.astype(np.int64)) ^ ry.astype(np.int64))
        flip = ~ry
        mirror = flip & rx
        x, y = np.where(mirror, side - 1 - x, x), np.where(mirror, side - 1 - y, y)
        x, y = np.where(flip, y, x), np.where(flip, x, y)
        s //= 2
    return np.lexsort((node_xy_m[:, 0], node_xy_m[:, 1], index))


if variant == "hilbert":
    cloud._morton_order = hilbert_order
if variant == "one block":
    mesh_module.BLOCK_ITEMS = 1 << 40

h = math.sqrt(2.0 * 0.2 / n_target)
sim = beam(h, 0.1)
xy = sim.nodes.xy_m
sim.run(20 * sim.dt_s)
nodes, scratch, mesh, mat, dt = sim.nodes, sim.scratch, sim.mesh_arrays, sim.material_arrays, sim.dt_s
half_beta_dt, min_bond_sq = 0.5 * 0.1 * dt, 0.25 * h * h
packed = np.zeros((len(xy), 9))


@njit
def smoothing(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    for _ in range(n):
        smooth_velocity_gradient(nodes.xy_m, nodes.velocity_m_s, mesh.elem_nodes, mesh.elem_block_ptr,
                                 mesh.elem_colour_ptr, mesh.elem_colour_block, scratch.velocity_gradient,
                                 scratch.area_m2, None)


@njit
def stress(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    for _ in range(n):
        update_stress(scratch.velocity_gradient, scratch.area_m2, nodes.stress_pa, nodes.plastic_strain,
                      nodes.material_row, mat.model, mat.lame_lambda_pa, mat.shear_modulus_pa, mat.params, dt, None)


@njit
def elements(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    for _ in range(n):
        for slot in range(mesh.elem_colour_block.shape[0]):
            block = mesh.elem_colour_block[slot]
            add_element_forces(nodes.xy_m, mesh.elem_nodes, nodes.stress_pa, mesh.elem_block_ptr[block],
                               mesh.elem_block_ptr[block + 1], scratch.force_n)


@njit
def bonds(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    for _ in range(n):
        for slot in range(mesh.edge_colour_block.shape[0]):
            block = mesh.edge_colour_block[slot]
            add_bond_forces(nodes.xy_m, nodes.velocity_m_s, scratch.velocity_gradient, scratch.area_m2,
                            nodes.material_row, mat.youngs_modulus_pa, mesh.edge_nodes, mesh.edge_block_ptr[block],
                            mesh.edge_block_ptr[block + 1], dt, half_beta_dt, min_bond_sq, scratch.force_n)


@njit
def packed_bonds(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    """``stabilisation.bond_force`` on one packed record per particle, the pack included."""
    node_xy, node_v, node_L, force, edge = nodes.xy_m, nodes.velocity_m_s, scratch.velocity_gradient, scratch.force_n, mesh.edge_nodes
    for _ in range(n):
        for k in range(node_xy.shape[0]):
            packed[k, 0], packed[k, 1] = node_xy[k, 0], node_xy[k, 1]
            packed[k, 2], packed[k, 3] = node_v[k, 0], node_v[k, 1]
            for c in range(4):
                packed[k, 4 + c] = node_L[k, c]
            packed[k, 8] = mat.youngs_modulus_pa[nodes.material_row[k]] * scratch.area_m2[k]
        for slot in range(mesh.edge_colour_block.shape[0]):
            block = mesh.edge_colour_block[slot]
            for bond in range(np.uint64(mesh.edge_block_ptr[block]), np.uint64(mesh.edge_block_ptr[block + 1])):
                i, j = np.uint64(edge[bond, 0]), np.uint64(edge[bond, 1])
                dx, dy = packed[j, 0] - packed[i, 0], packed[j, 1] - packed[i, 1]
                dvx, dvy = packed[j, 2] - packed[i, 2], packed[j, 3] - packed[i, 3]
                x0x, x0y = dx - dvx * dt, dy - dvy * dt
                length0_sq, length_sq = x0x * x0x + x0y * x0y, dx * dx + dy * dy
                if length0_sq <= 0.0 or length_sq <= 0.0:
                    continue
                err_i = ((packed[i, 4] * x0x + packed[i, 5] * x0y - dvx) * dx
                         + (packed[i, 6] * x0x + packed[i, 7] * x0y - dvy) * dy)
                err_j = ((packed[j, 4] * x0x + packed[j, 5] * x0y - dvx) * dx
                         + (packed[j, 6] * x0x + packed[j, 7] * x0y - dvy) * dy)
                factor = half_beta_dt * (packed[i, 8] * err_i + packed[j, 8] * err_j) / (
                    length_sq * max(length0_sq, min_bond_sq))
                force[j, 0] += factor * dx
                force[j, 1] += factor * dy
                force[i, 0] -= factor * dx
                force[i, 1] -= factor * dy


@njit
def leapfrog_pass(n, nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq, gravity, walls, h):
    for _ in range(n):  # dt = 0: the particles stay where they are
        leapfrog(nodes.xy_m, nodes.displacement_m, nodes.velocity_m_s, scratch.force_n, nodes.mass_kg,
                 nodes.inertia_kg, nodes.fixed, nodes.fixed_velocity_m_s, nodes.slip,
                 np.nonzero(nodes.slip[:, 2])[0], gravity, 0.7, 0.0,
                 walls.xy_m, walls.friction, h, scratch.contact, scratch.leapfrog_out, None)


passes = {{"smoothing": smoothing, "stress": stress, "elements": elements,
          "bonds": packed_bonds if variant == "packed bonds" else bonds, "leapfrog": leapfrog_pass}}
repetitions = max(20, int(1e7 / len(xy)))
arguments = (nodes, scratch, mesh, mat, packed, dt, half_beta_dt, min_bond_sq,
             np.asarray(sim.scene.gravity_m_s2, dtype=np.float64), sim.walls, h)
result = {{"n": len(xy)}}
for name, run in passes.items():
    run(2, *arguments)
    best = math.inf
    for _ in range(3):
        start = time.perf_counter()
        run(repetitions, *arguments)
        best = min(best, time.perf_counter() - start)
    result[name] = best / repetitions / len(xy) * 1e9
print(json.dumps(result))
'''


def measure(variant: str, n: int) -> dict:
    """One fresh-process measurement: ns per particle of every pass."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1")
    code = MEASURE.format(variant=variant, n=n)
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{variant}, {n} particles: measurement failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.step_passes", description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["1k", "100k"], choices=list(SIZES))
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes per figure, alternated (median)")
    args = parser.parse_args(argv)
    print(f"{'variant':>13} {'particles':>9}" + "".join(f" {name:>10}" for name in PASSES) + f" {'sum':>7}"
          + "   (ns per particle and pass, one thread; medians of alternated fresh processes)")
    sums: dict[tuple[str, str], float] = {}
    for size in args.sizes:
        runs: dict[str, list[dict]] = {variant: [] for variant in args.variants}
        for _ in range(args.repeats):
            for variant in args.variants:
                runs[variant].append(measure(variant, SIZES[size]))
        for variant, results in runs.items():
            medians = {name: statistics.median(r[name] for r in results) for name in PASSES}
            sums[variant, size] = sum(medians.values())
            print(f"{variant:>13} {results[0]['n']:9d}" + "".join(f" {medians[name]:10.2f}" for name in PASSES)
                  + f" {sums[variant, size]:7.2f}", flush=True)
    if len(args.sizes) > 1:
        small, large = args.sizes[0], args.sizes[-1]
        for variant in args.variants:
            print(f"{variant:>13}: sum at {large} over {small} (shipped at {small}): "
                  f"{sums[variant, large] / sums['shipped', small]:.3f}" if "shipped" in args.variants else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
