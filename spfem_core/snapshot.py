"""The values a simulation hands out: the particles at a moment, and the stress state a later
stage starts from.  Plain arrays (copies), no kernels: result files, metrics, figures and
ParaView read these, never the simulation's own arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class StressState:
    """What a stage leaves for the next one that starts from the initial positions (a gravity
    state for the strength-reduction runs): the effective stress (n, 4) xx, yy, zz, xy in Pa,
    tension positive, and the equivalent plastic strain (n,), the state strain softening reads."""

    stress_pa: np.ndarray
    plastic_strain: np.ndarray

    def __post_init__(self):
        stress = np.ascontiguousarray(self.stress_pa, dtype=np.float64)
        plastic = np.ascontiguousarray(self.plastic_strain, dtype=np.float64).reshape(-1)
        if stress.ndim != 2 or stress.shape[1] != 4 or plastic.shape != (stress.shape[0],):
            raise ValueError(f"StressState: expected stress (n, 4) and plastic strain (n,), got {stress.shape} and "
                             f"{plastic.shape}")
        if not (np.all(np.isfinite(stress)) and np.all(np.isfinite(plastic))):
            raise ValueError("StressState: values must be finite")
        object.__setattr__(self, "stress_pa", stress)
        object.__setattr__(self, "plastic_strain", plastic)

    @property
    def n_particles(self) -> int:
        return int(self.stress_pa.shape[0])


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The particles at one moment of a stage (copies of the simulation's arrays, SI units)."""

    time_s: float  # stage time of the moment (NaN: not during a stage)
    xy_m: np.ndarray  # (n, 2) positions
    initial_xy_m: np.ndarray  # (n, 2) positions at the start of the simulation
    displacement_m: np.ndarray  # (n, 2) since the particles last left their initial positions
    velocity_m_s: np.ndarray  # (n, 2) leapfrog half-step velocity
    stress_pa: np.ndarray  # (n, 4) effective stress xx, yy, zz, xy
    plastic_strain: np.ndarray  # (n,) equivalent plastic strain
    area_m2: np.ndarray  # (n,) smoothing-cell area on the current mesh
    mass_kg: np.ndarray  # (n,) per metre of thickness, fixed at the start
    density_kg_m3: np.ndarray  # (n,) mass density the mass was made with
    pore_pressure_pa: np.ndarray  # (n,) pore pressure at the current positions, compression positive
    material: np.ndarray  # (n,) int64 index of the particle's material in material_names
    material_names: tuple[str, ...]
    elem_nodes: np.ndarray  # (n_elem, 3) int64 triangles of the current mesh, counter-clockwise
    spacing_m: float  # nominal particle spacing h
    dt_s: float = math.nan  # time step in use
    critical_dt_s: float = math.nan  # critical time step of the current mesh
    particle_spacing_m: np.ndarray | None = None  # (n,) spacing of each particle of a graded cloud (None: uniform)

    @property
    def n_particles(self) -> int:
        return int(self.xy_m.shape[0])

    @property
    def meshed(self) -> np.ndarray:
        """(n,) True for the particles in a triangle of the current mesh (False: detached, in flight)."""
        meshed = np.zeros(self.n_particles, dtype=bool)
        meshed[self.elem_nodes.ravel()] = True
        return meshed

    @property
    def initial_area_m2(self) -> np.ndarray:
        """(n,) the area each particle stood for at the start, m_k / rho_k."""
        return self.mass_kg / self.density_kg_m3

    @property
    def stress_state(self) -> StressState:
        """The stress and plastic strain of this moment (what a later stage may start from)."""
        return StressState(self.stress_pa, self.plastic_strain)
