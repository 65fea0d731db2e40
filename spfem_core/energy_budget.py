"""The energy budget a stage records, by name: its columns and the accumulators of what is dissipated.

No kernels here (the study reader and the result-file declarations read these names without
numba).  Energies are per metre of out-of-plane thickness (J/m):

    kinetic             sum_k m_i,k |v_k|^2 / 2   (m_i the inertia: the mass, unless density-scaled)
    strain              sum_k A_k w(sigma_k),  w the complementary energy density of the
                        material's elasticity (``materials.elastic.elastic_energy_density``)
    gravity_potential   -sum_k m_k g . u_k   (relative to the initial positions, see NodeState)
    *_dissipated        the work removed by damping, stabilisation, plastic flow and the
                        walls since the stage start (``dissipated`` accumulators, >= 0)
    load_potential      minus the work done on the skeleton by pore water, ponded water and
                        surface loads since the stage start (``external_forces``); 0 without them

so that a stable undamped run keeps the sum of all columns constant (the energy balance).
"""

from __future__ import annotations

ENERGY_COLUMNS = (
    "kinetic",
    "strain",
    "gravity_potential",
    "damping_dissipated",
    "stabilisation_dissipated",
    "plastic_dissipated",
    "contact_dissipated",
    "load_potential",
)
"""Columns of the recorded energy array (J per metre of out-of-plane thickness)."""

ENERGY_KINETIC = 0
ENERGY_STRAIN = 1
ENERGY_GRAVITY_POTENTIAL = 2
ENERGY_LOAD_POTENTIAL = ENERGY_COLUMNS.index("load_potential")

DISSIPATION_COLUMNS = ("damping", "stabilisation", "plastic", "contact", "loads")
"""Slots of the ``dissipated`` accumulator array (J/m since the stage start; >= 0 but the loads'); slot i is
energy column ``DISSIPATED_FIRST_COLUMN + i``."""
DISSIPATED_DAMPING = 0
DISSIPATED_STABILISATION = 1
DISSIPATED_PLASTIC = 2
DISSIPATED_CONTACT = 3
DISSIPATED_LOADS = 4  # minus the work of water and surface loads (external_forces): their potential
DISSIPATED_FIRST_COLUMN = 3
