"""Per-particle soil properties (``Scene.node_properties``): any column of the material table given
per particle, the material row the default, strength reduction per particle."""

from __future__ import annotations

import numpy as np
import pytest

from spfem_core import MaterialTable, Scene, SolverSettings
from spfem_core.cloud import particles_in_polygon
from spfem_core.simulation import Simulation

SOIL = dict(density_kg_m3=2000.0, youngs_modulus_pa=2e7, poisson_ratio=0.3, cohesion_pa=2e3, friction_deg=15.0)
BLOCK_M = [[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]]


def block(node_properties=None, model="mohr_coulomb", spacing_m=0.25) -> Scene:
    """A block of soil on a fixed base, rollers on the sides, under gravity 50 m/s^2 (it yields at its base)."""
    xy = particles_in_polygon(BLOCK_M, spacing_m)
    materials = MaterialTable.single("soil", model, SOIL["density_kg_m3"], SOIL["youngs_modulus_pa"],
                                     SOIL["poisson_ratio"], SOIL["cohesion_pa"], SOIL["friction_deg"], 0.0)
    scene = Scene(xy, np.zeros(len(xy), dtype=np.int64), materials, spacing_m, gravity_m_s2=[0.0, -50.0],
                  node_properties=node_properties or {})
    scene.fix(scene.select_box(y_max=0.0), vx_m_s=0.0, vy_m_s=0.0)
    scene.fix(scene.select_box(x_max=0.0), vx_m_s=0.0)
    scene.fix(scene.select_box(x_min=4.0), vx_m_s=0.0)
    return scene


def n_particles() -> int:
    return len(particles_in_polygon(BLOCK_M, 0.25))


def run(scene: Scene, duration_s: float = 0.1) -> Simulation:
    sim = Simulation(scene, SolverSettings(cfl=0.5, stabilisation_beta=0.1))
    sim.run(duration_s, damping=0.2)
    return sim


@pytest.mark.parametrize("model", ["mohr_coulomb", "drucker_prager"])
def test_per_particle_values_equal_to_the_material_give_the_same_run_to_the_bit(model):
    """The per-particle path (a row per particle) computes exactly what the material row does."""
    n = n_particles()
    own = {"cohesion_pa": np.full(n, SOIL["cohesion_pa"]), "friction_deg": np.full(n, SOIL["friction_deg"]),
           "youngs_modulus_pa": np.full(n, SOIL["youngs_modulus_pa"])}
    shared, per_particle = run(block(model=model)), run(block(own, model=model))
    assert per_particle.particle_materials.n_rows == n and shared.particle_materials.n_rows == 1
    assert shared.nodes.plastic_strain.max() > 0.0  # the block yields: the return maps ran
    np.testing.assert_array_equal(per_particle.nodes.stress_pa, shared.nodes.stress_pa)
    np.testing.assert_array_equal(per_particle.nodes.xy_m, shared.nodes.xy_m)
    np.testing.assert_array_equal(per_particle.nodes.plastic_strain, shared.nodes.plastic_strain)


def test_a_weak_half_yields_and_the_strong_half_does_not():
    """Cohesion given per particle (NaN: the material's): the left half much stronger than the right."""
    scene = block()
    left = scene.node_xy_m[:, 0] < 2.0
    strong = np.where(left, 1e6, np.nan)
    sim = run(block({"cohesion_pa": strong}))
    interior = (scene.node_xy_m[:, 0] > 0.3) & (scene.node_xy_m[:, 0] < 3.7)
    assert np.all(sim.nodes.plastic_strain[left & interior] == 0.0)
    assert sim.nodes.plastic_strain[~left & interior].max() > 1e-5
    np.testing.assert_array_equal(sim.particle_materials.properties["cohesion_pa"],
                                  np.where(left, 1e6, SOIL["cohesion_pa"]))


def test_strength_reduction_divides_each_particles_own_strength():
    n = n_particles()
    cohesion = np.linspace(1e3, 9e3, n)
    friction = np.linspace(10.0, 40.0, n)
    table, rows = block({"cohesion_pa": cohesion, "friction_deg": friction}).particle_materials()
    np.testing.assert_array_equal(rows, np.arange(n))
    reduced = table.with_strength_reduction(1.5, associated=True)
    np.testing.assert_allclose(reduced.properties["cohesion_pa"], cohesion / 1.5, rtol=1e-15)
    np.testing.assert_allclose(np.tan(np.radians(reduced.properties["friction_deg"])),
                               np.tan(np.radians(friction)) / 1.5, rtol=1e-12)
    np.testing.assert_array_equal(reduced.properties["dilation_deg"], reduced.properties["friction_deg"])
    # the kernels' constants of each particle's row are those of a one-material table with its values
    for k in (0, n // 2, n - 1):
        phi_f = float(reduced.properties["friction_deg"][k])
        alone = MaterialTable.single("soil", "mohr_coulomb", 2000.0, 2e7, 0.3, cohesion[k] / 1.5, phi_f, phi_f)
        np.testing.assert_array_equal(reduced.kernel_constants()[k], alone.kernel_constants()[0])


def test_a_per_particle_density_sets_the_masses_alone():
    """Density only enters m_k = rho_k A_k: it needs no row per particle."""
    n = n_particles()
    density = np.linspace(1500.0, 2500.0, n)
    scene = block({"density_kg_m3": density})
    sim = Simulation(scene, SolverSettings())
    assert sim.particle_materials is scene.materials
    np.testing.assert_allclose(sim.nodes.mass_kg, density * sim.node_area_m2, rtol=1e-12)


@pytest.mark.parametrize("make, problem", [
    (lambda n: {"undrained_cohesion": np.ones(n)}, "no material property"),
    (lambda n: {"cohesion_pa": np.ones(2)}, "one value per particle"),
    (lambda n: {"density_kg_m3": np.full(n, -1.0)}, "densities must be > 0"),
    (lambda n: {"friction_deg": np.full(n, np.inf)}, "finite"),
])
def test_bad_per_particle_properties_are_refused(make, problem):
    with pytest.raises(ValueError, match=problem):
        block(make(n_particles()))


def test_a_per_particle_value_outside_its_range_names_the_property():
    n = n_particles()
    cohesion = np.full(n, 5e3)
    cohesion[7] = -1.0
    with pytest.raises(ValueError, match="cohesion_pa"):
        block({"cohesion_pa": cohesion}).particle_materials()
