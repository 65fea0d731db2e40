"""Locally refined clouds: the graded cloud, its first mesh, the memory estimate, the optional
density scaling, and a refined band giving the FOS of the uniform fine cloud with fewer particles."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.spatial import cKDTree

from spfem_core.cloud import graded_particles_in_polygon, particles_in_polygon, spacing_field
from spfem_core.geometry import signed_area_m2
from spfem_core.mesh import triangulate
from workflows.cases import RunOptions
from workflows.memory_guard import check_memory, estimated_particles
from workflows.scene import build_scene
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()
SLOPE = [[0.0, 0.0], [60.0, 0.0], [60.0, 5.0], [40.0, 5.0], [20.0, 15.0], [0.0, 15.0]]
ZONE = [[15.0, 15.5], [45.0, 5.5], [45.0, 2.0], [35.0, 2.0], [15.0, 10.0], [10.0, 15.5]]
BAND = """
[[geometry.refined]]
name = "mechanism"
region_m = [[16.0, 17.75], [18.0, 15.25], [22.0, 11.25], [26.0, 8.65], [30.0, 7.0], [34.0, 6.0], [38.0, 5.75],
            [42.0, 6.45], [42.0, 3.95], [38.0, 3.25], [34.0, 3.5], [30.0, 4.5], [26.0, 6.15], [22.0, 8.75],
            [18.0, 12.75], [16.0, 15.25]]
spacing_m = 0.5
"""


def mesh_area(xy, elem_nodes) -> float:
    a = xy[elem_nodes]
    return float(0.5 * np.abs((a[:, 1, 0] - a[:, 0, 0]) * (a[:, 2, 1] - a[:, 0, 1])
                              - (a[:, 2, 0] - a[:, 0, 0]) * (a[:, 1, 1] - a[:, 0, 1])).sum())


@pytest.mark.parametrize("grading", [1.1, 1.25, 1.5])
@pytest.mark.parametrize("jitter", [0.0, 0.1])
def test_a_graded_cloud_meshes_whole_and_grades_within_its_ratio(grading, jitter):
    """Every particle in the first mesh, no hole (the meshed area is the polygon's), no pair closer
    than 0.4 of its spacing less what the jitter may bring them together (sqrt(2) jitter h; the
    uniform cloud keeps h/2), and neighbours' spacings: 99% within 1.1 times the grading, all within
    the ratio of two levels (2, a little more where the jitter moves a particle across a border)."""
    xy, h = graded_particles_in_polygon(SLOPE, 1.0, [(ZONE, 0.25)], grading, jitter=jitter, seed=3)
    mesh = triangulate(xy, h)
    assert mesh.orphan_nodes.size == 0
    assert mesh_area(xy, mesh.elem_nodes) == pytest.approx(abs(signed_area_m2(SLOPE)), rel=1e-9)
    distance, _ = cKDTree(xy).query(xy, k=2)
    assert (distance[:, 1] / h).min() > 0.4 - jitter * math.sqrt(2.0)
    ratio = h[mesh.edge_nodes[:, 0]] / h[mesh.edge_nodes[:, 1]]
    ratio = np.maximum(ratio, 1.0 / ratio)
    assert np.percentile(ratio, 99) <= 1.1 * grading and ratio.max() <= 2.0 * (1.0 + 2.0 * jitter)


def test_the_spacing_is_the_zones_inside_and_grows_with_distance_outside():
    xy, h = graded_particles_in_polygon(SLOPE, 1.0, [(ZONE, 0.25)], 1.25)
    field = spacing_field(xy, 1.0, [(ZONE, 0.25)], 1.25)
    inside = field == 0.25
    assert np.all(h[inside] == 0.25) and inside.sum() > 1000
    assert np.all(h[field == 1.0] == 1.0)
    assert np.all(h >= field - 1e-12)  # each particle carries h(x)
    assert np.array_equal(graded_particles_in_polygon(SLOPE, 1.0, [(ZONE, 0.25)], 1.25)[0], xy)  # deterministic
    uniform, ones = graded_particles_in_polygon(SLOPE, 1.0, [], 1.25)
    assert np.array_equal(uniform, particles_in_polygon(SLOPE, 1.0)) and np.all(ones == 1.0)


def test_a_per_particle_spacing_equal_everywhere_gives_the_same_mesh():
    xy = particles_in_polygon(SLOPE, 0.5, jitter=0.1)
    assert np.array_equal(triangulate(xy, np.full(len(xy), 0.5)).elem_nodes, triangulate(xy, 0.5).elem_nodes)


def test_the_particle_estimate_of_a_refined_study_is_close_to_the_count():
    study = parse_study(QUICKSTART + BAND)
    count = build_scene(study).n_particles
    assert estimated_particles(study) == pytest.approx(count, rel=0.15)
    assert count < build_scene(parse_study(QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 0.5"))).n_particles / 2


@pytest.mark.parametrize("zone_spacing_m, blamed", [(1e-4, "geometry.refined[0].spacing_m: 0.0001 m"),
                                                     (0.9, "geometry.spacing_m: 1 m")])
def test_a_study_too_large_names_the_spacing_that_makes_most_particles(zone_spacing_m, blamed):
    """A refined zone at 1e-4 m makes billions of particles: the refusal names the zone's spacing, not
    geometry.spacing_m; a zone hardly finer than the cloud leaves the blame on geometry.spacing_m."""
    study = parse_study(QUICKSTART + BAND.replace("spacing_m = 0.5", f"spacing_m = {zone_spacing_m}"))
    with pytest.raises(StudyError, match=f"^{re.escape(blamed)} gives about"):
        check_memory(study, processes=1, limit_bytes=1000.0)


@pytest.mark.parametrize("block, field, message", [
    (BAND.replace("spacing_m = 0.5", "spacing_m = 1.5"), "geometry.refined[0].spacing_m", "coarser"),
    ("\n[geometry]\ngrading = 2.0\n", None, None),
])
def test_bad_refined_zones_name_the_field(block, field, message):
    if field is None:  # grading is a field of [geometry]: write it there
        text = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 1.0\ngrading = 2.0")
        field, message = "geometry.grading", "<= 1.5"
    else:
        text = QUICKSTART + block
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == field and message in str(error.value)


def test_density_scaling_relaxes_to_the_same_gravity_stresses():
    """The gravity stage of the refined quickstart with and without density scaling: the same
    relaxed stresses within 1% of rho g H (only the path to rest differs)."""
    from workflows.fos.gravity import run_gravity

    text = QUICKSTART + BAND
    plain = run_gravity(text).state.stress_pa
    scaled = run_gravity(text.replace("stabilisation_beta = 0.1", "stabilisation_beta = 0.1\ndensity_scaling = true"))
    assert np.abs(scaled.state.stress_pa - plain).max() <= 0.01 * 2000.0 * 10.0 * 15.0


@pytest.fixture(scope="module")
def fine_quickstart(tmp_path_factory):
    """The quickstart on a uniform 0.5 m cloud (2,536 particles), run once."""
    text = QUICKSTART.replace("spacing_m = 1.0", "spacing_m = 0.5")
    return run_study(parse_study(text), tmp_path_factory.mktemp("fine"), RunOptions(workers=2))


def test_a_refined_band_gives_the_fos_of_the_uniform_fine_cloud_with_fewer_particles(fine_quickstart, tmp_path):
    """The quickstart at h = 1 m with a band of 0.5 m along its slip surface, against the uniform
    0.5 m cloud: the same FOS within the search tolerance."""
    band = run_study(parse_study(QUICKSTART + BAND), tmp_path / "band", RunOptions(workers=2))
    fine = fine_quickstart
    assert math.isfinite(band.fos) and abs(band.fos - fine.fos) <= 0.01
    assert band.n_particles < 0.6 * fine.n_particles
    assert (tmp_path / "band" / "particle_spacing.png").is_file()
    with xr.open_dataset(tmp_path / "band" / "gravity.nc") as gravity:
        assert gravity["particle_spacing"].values.min() == 0.5 and gravity["particle_spacing"].values.max() == 1.0
