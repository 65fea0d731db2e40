"""What a mesh rebuild and the in-loop quality check cost, piece by piece.

    python -m benchmarks.bench_rebuild

Clouds: the granular column (0.2 x 0.1 m) at h = 4 mm and 1 mm, jittered by 0.25 h and
sheared by 0.5 (x += 0.5 y) so that the triangles are as uneven as in a flow.  For each:
median wall time of Qhull's Delaunay, the whole ``triangulate`` (Delaunay + alpha shape +
adjacency), the adjacency alone, and ``np.unique`` over edge keys (the adjacency's earlier
method); then the exact smallest-angle check against the plain all-corner atan2 definition
(``verification.probes.all_corners_min_angle``), and whether the two agree to the bit.
"""

from __future__ import annotations

import statistics
import time
from functools import partial

import numpy as np

from spfem_core.cloud import particles_in_polygon
from spfem_core.mesh import delaunay_triangles, element_quality_min_angle, mesh_from_elements, triangulate
from verification.probes import all_corners_min_angle

COLUMN = [(0.0, 0.0), (0.2, 0.0), (0.2, 0.1), (0.0, 0.1)]


def median_ms(call, repeats: int) -> float:
    call()  # compiled code loaded, caches hot
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def unique_key_adjacency(elem_nodes: np.ndarray, n_nodes: int) -> np.ndarray:
    """The earlier node->node step: directed edge keys i n + j made unique by np.unique."""
    first = elem_nodes.ravel()
    second = elem_nodes[:, [1, 2, 0]].ravel()
    return np.unique(np.concatenate([first * n_nodes + second, second * n_nodes + first]))


def main() -> None:
    print(f"{'h (mm)':>6} {'particles':>9} {'elements':>8} {'Delaunay':>9} {'triangulate':>11} {'adjacency':>9} "
          f"{'np.unique':>9} {'check':>7} {'all-corner':>10} {'same bits':>9}   (ms)")
    for spacing_m in (0.004, 0.001):
        xy = particles_in_polygon(COLUMN, spacing_m, jitter=0.25, seed=7)
        xy[:, 0] += 0.5 * xy[:, 1]
        mesh = triangulate(xy, spacing_m)
        elem, n = mesh.elem_nodes, len(xy)
        repeats = 50 if n < 5000 else 15
        row = [
            median_ms(partial(delaunay_triangles, xy), repeats),
            median_ms(partial(triangulate, xy, spacing_m), repeats),
            median_ms(partial(mesh_from_elements, elem, n), repeats),
            median_ms(partial(unique_key_adjacency, elem, n), repeats),
            median_ms(partial(element_quality_min_angle, xy, elem), 5 * repeats),
            median_ms(partial(all_corners_min_angle, xy, elem), 5 * repeats),
        ]
        same = element_quality_min_angle(xy, elem) == all_corners_min_angle(xy, elem)
        print(f"{1e3 * spacing_m:6.0f} {n:9d} {mesh.n_elem:8d} " + " ".join(
            f"{value:{width}.2f}" for value, width in zip(row, (9, 11, 9, 9, 7, 10))) + f" {str(same):>9}")


if __name__ == "__main__":
    main()
