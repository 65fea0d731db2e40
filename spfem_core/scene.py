"""What a simulation is made of: particles, materials, boundary conditions, loads.

All arrays are SI units, float64 or int64, C-contiguous; vectors are (n, 2) and the
plane-strain stress is (n, 4) ordered (xx, yy, zz, xy), tension positive.  The numerical
settings of a run are ``settings.SolverSettings``; the material rows ``materials.table.MaterialTable``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spfem_core.materials.table import ELASTIC_COLUMNS, PROPERTY_MODELS, MaterialTable
from spfem_core.settings import DEFAULT_ALPHA

PER_PARTICLE_MASS_ONLY = ("density_kg_m3",)
"""Per-particle properties that only set the masses m_k = rho_k A_k (fixed at the start): they need
no row per particle in the material table."""


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
    spacing_m: float  # nominal particle spacing h; of a graded cloud, its finest spacing
    gravity_m_s2: np.ndarray = field(default_factory=lambda: np.array([0.0, -9.81]))
    node_fixed: np.ndarray | None = None  # (n, 2) bool
    node_fixed_velocity_m_s: np.ndarray | None = None  # (n, 2)
    node_slip_length_m: np.ndarray | None = None  # (n,) share L_k of a slip support (0: none); see StageSetup
    node_slip_side: np.ndarray | None = None  # (n,) side s = +-1 its support lies on (0: none)
    alpha: float = DEFAULT_ALPHA  # alpha-shape factor: drop triangles with circumradius > alpha * h
    wall_xy_m: np.ndarray | None = None  # (n_wall, 4) rigid segments (x1, y1, x2, y2); material on the left
    wall_friction: np.ndarray | None = None  # (n_wall,) Coulomb coefficient mu
    node_properties: dict = field(default_factory=dict)  # name -> (n,) a material column per particle; NaN: its own
    node_load_n: np.ndarray | None = None  # (n, 2) constant forces on the particles (surface loads), N/m
    node_pore_pressure_pa: np.ndarray | None = None  # (n,) pore pressure carried by the particle (ru), Pa
    phreatic_lines_m: tuple = ()  # piezometric lines, each (n_points, 2) with x strictly increasing
    node_phreatic_line: np.ndarray | None = None  # (n,) int64 line of each particle in phreatic_lines_m; -1: none
    pond_level_m: float | None = None  # level of water standing on the ground surface (m)
    pond_x_range_m: tuple = (-np.inf, np.inf)  # the pond stands on the surface between these x only (a reservoir)
    water_unit_weight_n_m3: float = 9810.0  # gamma_w
    node_spacing_m: np.ndarray | None = None  # (n,) spacing of each particle of a graded cloud (None: spacing_m)

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
        for attr in ("node_slip_length_m", "node_slip_side"):
            value = np.zeros(n) if getattr(self, attr) is None else getattr(self, attr)
            setattr(self, attr, np.ascontiguousarray(value, dtype=np.float64).reshape(n))
        self.gravity_m_s2 = np.ascontiguousarray(self.gravity_m_s2, dtype=np.float64).reshape(2)
        walls = np.zeros((0, 4)) if self.wall_xy_m is None else self.wall_xy_m
        self.wall_xy_m = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        friction = np.zeros(self.wall_xy_m.shape[0]) if self.wall_friction is None else self.wall_friction
        self.wall_friction = np.ascontiguousarray(friction, dtype=np.float64).reshape(-1)
        if self.wall_friction.shape[0] != self.wall_xy_m.shape[0]:
            raise ValueError("Scene.wall_friction: one coefficient per wall expected")
        if not self.spacing_m > 0:
            raise ValueError(f"Scene.spacing_m: must be > 0, got {self.spacing_m}")
        if self.node_spacing_m is not None:
            self.node_spacing_m = np.ascontiguousarray(self.node_spacing_m, dtype=np.float64).reshape(-1)
            if self.node_spacing_m.shape != (n,) or not np.all(self.node_spacing_m >= self.spacing_m * (1 - 1e-9)):
                raise ValueError("Scene.node_spacing_m: one spacing per particle, each >= spacing_m")
        for attr, shape in (("node_load_n", (n, 2)), ("node_pore_pressure_pa", (n,))):
            value = getattr(self, attr)
            if value is not None:
                value = np.ascontiguousarray(value, dtype=np.float64).reshape(shape)
                if not np.all(np.isfinite(value)):
                    raise ValueError(f"Scene.{attr}: values must be finite")
                setattr(self, attr, value)
        self.node_properties = {key: self._checked_property(key, values)
                                for key, values in self.node_properties.items()}
        lines = []
        for i, line in enumerate(self.phreatic_lines_m):
            line = np.ascontiguousarray(line, dtype=np.float64).reshape(-1, 2)
            if line.shape[0] < 2 or not np.all(np.diff(line[:, 0]) > 0) or not np.all(np.isfinite(line)):
                raise ValueError(f"Scene.phreatic_lines_m[{i}]: at least 2 finite points with x strictly increasing")
            lines.append(line)
        self.phreatic_lines_m = tuple(lines)
        if self.node_phreatic_line is None:
            self.node_phreatic_line = np.full(n, 0 if lines else -1, dtype=np.int64)
        self.node_phreatic_line = np.ascontiguousarray(self.node_phreatic_line, dtype=np.int64).reshape(-1)
        if self.node_phreatic_line.shape != (n,) or (n and (self.node_phreatic_line.min() < -1
                                                          or self.node_phreatic_line.max() >= len(lines))):
            raise ValueError("Scene.node_phreatic_line: one index into phreatic_lines_m (or -1) per particle expected")
        if not self.water_unit_weight_n_m3 > 0:
            raise ValueError(f"Scene.water_unit_weight_n_m3: must be > 0, got {self.water_unit_weight_n_m3}")

    def _checked_property(self, key: str, values) -> np.ndarray:
        """A per-particle property as an (n,) float64 array: a column of the material table, finite or
        NaN (the particle's material value), a density > 0."""
        if key not in ELASTIC_COLUMNS and key not in PROPERTY_MODELS:
            raise ValueError(f"Scene.node_properties: {key!r} is no material property "
                             f"(known: {', '.join(ELASTIC_COLUMNS + tuple(PROPERTY_MODELS))})")
        values = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
        if values.shape != (self.n_particles,):
            raise ValueError(f"Scene.node_properties[{key!r}]: one value per particle expected, got {values.shape[0]}")
        if np.any(np.isinf(values)) and key != "tensile_strength_pa":
            raise ValueError(f"Scene.node_properties[{key!r}]: values must be finite (NaN: the material's)")
        if key == "density_kg_m3" and not np.all(np.isnan(values) | (values > 0.0)):
            raise ValueError("Scene.node_properties['density_kg_m3']: densities must be > 0")
        return values

    @property
    def particle_density_kg_m3(self) -> np.ndarray:
        """Mass density of every particle (n,): its own (``node_properties``) or its material's."""
        density = self.materials.density_kg_m3[self.node_material]
        own = self.node_properties.get("density_kg_m3")
        return density if own is None else np.where(np.isnan(own), density, own)

    def particle_materials(self) -> tuple[MaterialTable, np.ndarray]:
        """(the material table a simulation reads, the row of every particle in it).

        Without per-particle properties (or with a per-particle density alone, which sets only the
        masses): ``materials`` and ``node_material``.  Otherwise a row per particle, its material's
        with the particle's own values, and row k for particle k; strength reduction then acts on
        every particle's own strength."""
        if set(self.node_properties) <= set(PER_PARTICLE_MASS_ONLY):
            return self.materials, self.node_material
        per_particle = self.materials.rows(self.node_material).with_values(self.node_properties)
        return per_particle, np.arange(self.n_particles, dtype=np.int64)

    @property
    def n_particles(self) -> int:
        return self.node_xy_m.shape[0]

    def select_box(self, x_min=-np.inf, x_max=np.inf, y_min=-np.inf, y_max=np.inf) -> np.ndarray:
        """Indices of particles whose initial position lies in the closed box (tolerance h/1000)."""
        tol = 1e-3 * self.spacing_m
        x, y = self.node_xy_m[:, 0], self.node_xy_m[:, 1]
        inside = (x >= x_min - tol) & (x <= x_max + tol) & (y >= y_min - tol) & (y <= y_max + tol)
        return np.flatnonzero(inside)

    def add_wall(self, x1_m, y1_m, x2_m, y2_m, friction=0.0) -> None:
        """A rigid segment from (x1, y1) to (x2, y2); material lies on its left (a floor runs +x)."""
        self.wall_xy_m = np.ascontiguousarray(np.vstack([self.wall_xy_m, [[x1_m, y1_m, x2_m, y2_m]]]))
        self.wall_friction = np.ascontiguousarray(np.append(self.wall_friction, friction))

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
