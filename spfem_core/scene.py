"""What a simulation is made of: particles, materials, boundary conditions, numerics.

All arrays are SI units, float64 or int64, C-contiguous; vectors are (n, 2) and the
plane-strain stress is (n, 4) ordered (xx, yy, zz, xy), tension positive.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

MODEL_ELASTIC = 0
"""Material model code: linear elastic (the only model of this version)."""

MODEL_NAMES = {"elastic": MODEL_ELASTIC}


@dataclass(frozen=True)
class MaterialTable:
    """Per-material constants; a particle refers to a row by its ``node_material`` index."""

    name: tuple[str, ...]
    model: np.ndarray  # (n_mat,) int64, one of the MODEL_* codes
    density_kg_m3: np.ndarray  # (n_mat,)
    youngs_modulus_pa: np.ndarray  # (n_mat,)
    poisson_ratio: np.ndarray  # (n_mat,)

    def __post_init__(self):
        n = len(self.name)
        for attr in ("model", "density_kg_m3", "youngs_modulus_pa", "poisson_ratio"):
            dtype = np.int64 if attr == "model" else np.float64
            value = np.ascontiguousarray(getattr(self, attr), dtype=dtype).reshape(-1)
            if value.shape != (n,):
                raise ValueError(f"MaterialTable.{attr}: expected {n} values, got {value.shape[0]}")
            object.__setattr__(self, attr, value)

    @classmethod
    def elastic(cls, name: str, density_kg_m3: float, youngs_modulus_pa: float, poisson_ratio: float):
        """A table with a single linear elastic material."""
        return cls((name,), [MODEL_ELASTIC], [density_kg_m3], [youngs_modulus_pa], [poisson_ratio])

    @property
    def shear_modulus_pa(self) -> np.ndarray:
        """G = E / (2 (1 + nu))."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def bulk_modulus_pa(self) -> np.ndarray:
        """K = E / (3 (1 - 2 nu))."""
        return self.youngs_modulus_pa / (3.0 * (1.0 - 2.0 * self.poisson_ratio))

    @property
    def p_wave_speed_m_s(self) -> np.ndarray:
        """c_p = sqrt((K + 4G/3) / rho), the fastest wave of the material."""
        return np.sqrt((self.bulk_modulus_pa + 4.0 * self.shear_modulus_pa / 3.0) / self.density_kg_m3)


@dataclass
class Scene:
    """A particle cloud with its materials, boundary conditions and loads.

    ``node_fixed[k, d]`` is True where the velocity of particle k in direction d is
    prescribed as ``node_fixed_velocity_m_s[k, d]`` (0 for a fixed or roller support).
    Boundary conditions are assigned from the initial coordinates and carried by the particle.
    """

    node_xy_m: np.ndarray  # (n, 2) initial positions
    node_material: np.ndarray  # (n,) int64 row of ``materials``
    materials: MaterialTable
    spacing_m: float  # nominal particle spacing h
    gravity_m_s2: np.ndarray = field(default_factory=lambda: np.array([0.0, -9.81]))
    node_fixed: np.ndarray | None = None  # (n, 2) bool
    node_fixed_velocity_m_s: np.ndarray | None = None  # (n, 2)
    alpha: float = 1.5  # alpha-shape factor: drop triangles with circumradius > alpha * h

    def __post_init__(self):
        self.node_xy_m = np.ascontiguousarray(self.node_xy_m, dtype=np.float64)
        n = self.node_xy_m.shape[0]
        if self.node_xy_m.ndim != 2 or self.node_xy_m.shape[1] != 2:
            raise ValueError(f"Scene.node_xy_m: expected shape (n, 2), got {self.node_xy_m.shape}")
        self.node_material = np.ascontiguousarray(self.node_material, dtype=np.int64).reshape(-1)
        if self.node_material.shape != (n,):
            raise ValueError("Scene.node_material: one material index per particle expected")
        if n and (self.node_material.min() < 0 or self.node_material.max() >= len(self.materials.name)):
            raise ValueError("Scene.node_material: index outside the material table")
        if self.node_fixed is None:
            self.node_fixed = np.zeros((n, 2), dtype=bool)
        self.node_fixed = np.ascontiguousarray(self.node_fixed, dtype=bool)
        if self.node_fixed_velocity_m_s is None:
            self.node_fixed_velocity_m_s = np.zeros((n, 2))
        self.node_fixed_velocity_m_s = np.ascontiguousarray(self.node_fixed_velocity_m_s, dtype=np.float64)
        self.gravity_m_s2 = np.ascontiguousarray(self.gravity_m_s2, dtype=np.float64).reshape(2)
        if not self.spacing_m > 0:
            raise ValueError(f"Scene.spacing_m: must be > 0, got {self.spacing_m}")

    @property
    def n_particles(self) -> int:
        return self.node_xy_m.shape[0]

    def select_box(self, x_min=-np.inf, x_max=np.inf, y_min=-np.inf, y_max=np.inf) -> np.ndarray:
        """Indices of particles whose initial position lies in the closed box (tolerance h/1000)."""
        tol = 1e-3 * self.spacing_m
        x, y = self.node_xy_m[:, 0], self.node_xy_m[:, 1]
        inside = (x >= x_min - tol) & (x <= x_max + tol) & (y >= y_min - tol) & (y <= y_max + tol)
        return np.flatnonzero(inside)

    def fix(self, nodes: np.ndarray, vx_m_s: float | None = None, vy_m_s: float | None = None) -> None:
        """Prescribe the velocity of ``nodes`` in x and/or y (None leaves that direction free)."""
        for d, value in enumerate((vx_m_s, vy_m_s)):
            if value is not None:
                self.node_fixed[nodes, d] = True
                self.node_fixed_velocity_m_s[nodes, d] = value

    def nearest_particle(self, x_m: float, y_m: float) -> int:
        """Index of the particle nearest to (x, y) in the initial configuration."""
        d2 = (self.node_xy_m[:, 0] - x_m) ** 2 + (self.node_xy_m[:, 1] - y_m) ** 2
        return int(np.argmin(d2))


@dataclass(frozen=True)
class SolverSettings:
    """Numerical parameters of a run (the physics lives in :class:`Scene`).

    Time step: ``dt_s`` if given, else ``cfl * h_alt_min / c_p_max`` with h_alt_min the
    smallest triangle altitude and c_p_max the fastest P-wave speed.  A cfl (or a ``dt_s``
    equivalent to one) above ``simulation.max_stable_cfl(beta) = 1 / (1 + beta)`` is refused.

    ``stabilisation_beta`` scales the rank-deficiency correction (0 switches it off and
    its work is skipped).  The correction force is proportional to the incremental
    deformation error over one step, so it acts as a bond viscosity eta = beta E dt / 2:
    at fixed beta, halving dt halves the damping it applies to spurious modes.
    """

    cfl: float = 0.5
    dt_s: float | None = None
    stabilisation_beta: float = 0.0
    max_quality_drop_deg: float = 0.0  # reserved for adaptive remeshing (issue [2/4])
    min_angle_deg: float = 5.0  # rebuild the mesh when the smallest angle falls below this
