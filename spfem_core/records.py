"""What a stage records: monitor histories, the energy budget and the largest displacement.

The compiled loop writes one row every record interval of stage time into growable buffers
(:class:`RecordBuffers`, one named array per quantity); a finished stage hands them over as a
:class:`TimeSeries`.  The energy columns and their equations: ``energy_budget``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from spfem_core.energy_budget import (
    DISSIPATED_FIRST_COLUMN,
    ENERGY_COLUMNS,
    ENERGY_GRAVITY_POTENTIAL,
    ENERGY_KINETIC,
    ENERGY_STRAIN,
)
from spfem_core.jit import kernel
from spfem_core.materials.elastic import elastic_energy_density
from spfem_core.state import STRESS_WIDTH, XX, XY, YY, ZZ


class RecordBuffers(NamedTuple):
    """Rows written by the compiled loop; ``count[0]`` rows are filled."""

    time_s: np.ndarray  # (capacity,) stage time of the row
    monitor_displacement_m: np.ndarray  # (capacity, n_monitor, 2)
    monitor_velocity_m_s: np.ndarray  # (capacity, n_monitor, 2)
    monitor_stress_pa: np.ndarray  # (capacity, n_monitor, 4) xx, yy, zz, xy
    energy_j_per_m: np.ndarray  # (capacity, len(ENERGY_COLUMNS))
    max_displacement_m: np.ndarray  # (capacity,) largest |u| of any particle
    max_speed_m_s: np.ndarray  # (capacity,) largest |v| of any particle
    count: np.ndarray  # (1,) int64 rows filled

    @classmethod
    def empty(cls, capacity: int, n_monitor: int) -> RecordBuffers:
        """Buffers for ``capacity`` rows, none filled."""
        return cls(
            np.zeros(capacity),
            np.zeros((capacity, n_monitor, 2)),
            np.zeros((capacity, n_monitor, 2)),
            np.zeros((capacity, n_monitor, STRESS_WIDTH)),
            np.zeros((capacity, len(ENERGY_COLUMNS))),
            np.zeros(capacity),
            np.zeros(capacity),
            np.zeros(1, dtype=np.int64),
        )

    @property
    def capacity(self) -> int:
        return int(self.time_s.shape[0])

    @property
    def n_filled(self) -> int:
        return int(self.count[0])

    def grown(self) -> RecordBuffers:
        """Twice the capacity, with the filled rows copied."""
        new = RecordBuffers.empty(2 * self.capacity, self.monitor_displacement_m.shape[1])
        for old_array, new_array in zip(self[:-1], new[:-1]):
            new_array[: self.capacity] = old_array
        new.count[0] = self.count[0]
        return new

    def filled(self) -> RecordBuffers:
        """Copies of the filled rows only."""
        n = self.n_filled
        return RecordBuffers(*(array[:n].copy() for array in self[:-1]), self.count.copy())


@kernel
def record_state(slot, time_s, nodes, node_area, materials, gravity, monitor_nodes, dissipated, records):
    """Write the monitors, the energies (module doc) and the largest displacement into row ``slot``
    of ``records``; ``nodes`` a ``state.NodeState``, ``materials`` a ``state.MaterialArrays``."""
    records.time_s[slot] = time_s
    node_u = nodes.displacement_m
    node_v = nodes.velocity_m_s
    node_stress = nodes.stress_pa
    for m in range(monitor_nodes.shape[0]):
        k = monitor_nodes[m]
        for d in range(2):
            records.monitor_displacement_m[slot, m, d] = node_u[k, d]
            records.monitor_velocity_m_s[slot, m, d] = node_v[k, d]
        for c in range(STRESS_WIDTH):
            records.monitor_stress_pa[slot, m, c] = node_stress[k, c]
    kinetic = 0.0
    strain = 0.0
    potential = 0.0
    max_u_sq = 0.0
    max_v_sq = 0.0
    for k in range(node_u.shape[0]):
        mass = nodes.mass_kg[k]
        vx = node_v[k, 0]
        vy = node_v[k, 1]
        ux = node_u[k, 0]
        uy = node_u[k, 1]
        kinetic += 0.5 * nodes.inertia_kg[k] * (vx * vx + vy * vy)  # the mass the forces accelerate
        potential -= mass * (gravity[0] * ux + gravity[1] * uy)
        row = nodes.material_row[k]
        strain += node_area[k] * elastic_energy_density(
            node_stress[k, XX], node_stress[k, YY], node_stress[k, ZZ], node_stress[k, XY],
            materials.youngs_modulus_pa[row], materials.poisson_ratio[row],
        )
        u_sq = ux * ux + uy * uy
        if u_sq > max_u_sq:
            max_u_sq = u_sq
        v_sq = vx * vx + vy * vy
        if v_sq > max_v_sq:
            max_v_sq = v_sq
    energy = records.energy_j_per_m
    energy[slot, ENERGY_KINETIC] = kinetic
    energy[slot, ENERGY_STRAIN] = strain
    energy[slot, ENERGY_GRAVITY_POTENTIAL] = potential
    for i in range(dissipated.shape[0]):
        energy[slot, DISSIPATED_FIRST_COLUMN + i] = dissipated[i]
    records.max_displacement_m[slot] = math.sqrt(max_u_sq)
    records.max_speed_m_s[slot] = math.sqrt(max_v_sq)


@dataclass
class TimeSeries:
    """What a stage recorded: one row per record time (stage time, seconds from its start)."""

    time_s: np.ndarray  # (n_rec,)
    monitor_displacement_m: np.ndarray  # (n_rec, n_monitor, 2)
    monitor_velocity_m_s: np.ndarray  # (n_rec, n_monitor, 2)
    monitor_stress_pa: np.ndarray  # (n_rec, n_monitor, 4) xx, yy, zz, xy
    energy_j_per_m: np.ndarray  # (n_rec, len(ENERGY_COLUMNS)), see energy()
    max_displacement_m: np.ndarray  # (n_rec,)
    max_speed_m_s: np.ndarray  # (n_rec,)
    dt_s: float
    n_steps: int
    n_remesh: int
    n_mesh_checks: int
    wall_time_s: float
    converged: bool | None = None  # relaxation only
    unbalanced_force_ratio: float = math.nan  # at the last step
    notes: dict = field(default_factory=dict)

    @classmethod
    def from_records(cls, records: RecordBuffers, **counters) -> TimeSeries:
        """The filled rows of ``records`` with the stage's counters (the other fields)."""
        rows = records.filled()
        return cls(
            time_s=rows.time_s, monitor_displacement_m=rows.monitor_displacement_m,
            monitor_velocity_m_s=rows.monitor_velocity_m_s, monitor_stress_pa=rows.monitor_stress_pa,
            energy_j_per_m=rows.energy_j_per_m, max_displacement_m=rows.max_displacement_m,
            max_speed_m_s=rows.max_speed_m_s, **counters,
        )

    def energy(self, name: str) -> np.ndarray:
        """The energy column ``name`` (one of :data:`ENERGY_COLUMNS`), J/m per record."""
        return self.energy_j_per_m[:, ENERGY_COLUMNS.index(name)]

    @property
    def energy_total_j_per_m(self) -> np.ndarray:
        """Sum of every column: constant in a run that creates no energy (module doc)."""
        return self.energy_j_per_m.sum(axis=1)

    @property
    def kinetic_energy_j_per_m(self) -> np.ndarray:
        return self.energy_j_per_m[:, ENERGY_KINETIC]
