"""What a simulation is made of: particles, materials, boundary conditions, numerics.

All arrays are SI units, float64 or int64, C-contiguous; vectors are (n, 2) and the
plane-strain stress is (n, 4) ordered (xx, yy, zz, xy), tension positive.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from spfem_core.plasticity import default_dp_fit, dp_constants

MODEL_ELASTIC = 0
MODEL_DRUCKER_PRAGER = 1
MODEL_MOHR_COULOMB = 2
"""Material model codes carried by ``MaterialTable.model``."""

MODEL_NAMES = {"elastic": MODEL_ELASTIC, "drucker_prager": MODEL_DRUCKER_PRAGER, "mohr_coulomb": MODEL_MOHR_COULOMB}

N_MODEL_PARAMS = 11
"""Columns of the compiled model constants (``MaterialTable.model_params``):
Drucker-Prager (alpha, k in Pa, alpha_psi, 0, tensile strength in Pa); Mohr-Coulomb (c in Pa, sin phi,
cos phi, sin psi, tensile strength in Pa).  An infinite tensile strength: no tension cut-off.
Columns 5-10, strain softening of Mohr-Coulomb (``SOFTENING_*``): residual c (Pa), residual phi (rad),
peak phi (rad), plastic strain where softening starts, where it ends, the law code."""

SOFTENING_NONE = 0
SOFTENING_LINEAR = 1
SOFTENING_EXPONENTIAL = 2
SOFTENING_LAWS = {"linear": SOFTENING_LINEAR, "exponential": SOFTENING_EXPONENTIAL}
"""Strain-softening laws: with eps the equivalent plastic strain, s(eps) the share of the drop from
peak to residual: linear s = clip((eps - eps_1) / (eps_2 - eps_1), 0, 1); exponential
s = 1 - exp(-3 (eps - eps_1) / (eps_2 - eps_1)) above eps_1 (95% of the drop at eps_2)."""


@dataclass(frozen=True)
class MaterialTable:
    """Per-material constants; a particle refers to a row by its ``node_material`` index.

    Strength (c, phi, psi) is ignored by elastic rows.  ``dp_fit`` names the Drucker-Prager
    match to Mohr-Coulomb (``plasticity.DP_FITS``; empty: the default fit for the dilation).
    """

    name: tuple[str, ...]
    model: np.ndarray  # (n_mat,) int64, one of the MODEL_* codes
    density_kg_m3: np.ndarray  # (n_mat,)
    youngs_modulus_pa: np.ndarray  # (n_mat,)
    poisson_ratio: np.ndarray  # (n_mat,)
    cohesion_pa: np.ndarray | None = None  # (n_mat,) c
    friction_deg: np.ndarray | None = None  # (n_mat,) phi
    dilation_deg: np.ndarray | None = None  # (n_mat,) psi
    dp_fit: tuple[str, ...] | None = None
    tensile_strength_pa: np.ndarray | None = None  # (n_mat,) tension cut-off sigma_t; inf (default): none
    softening_law: np.ndarray | None = None  # (n_mat,) int64 SOFTENING_* code (Mohr-Coulomb only); 0: none
    residual_cohesion_pa: np.ndarray | None = None  # (n_mat,) c once softened
    residual_friction_deg: np.ndarray | None = None  # (n_mat,) phi once softened
    softening_start_strain: np.ndarray | None = None  # (n_mat,) equivalent plastic strain where it starts
    softening_end_strain: np.ndarray | None = None  # (n_mat,) where it ends (exponential: 95% of the drop)

    def __post_init__(self):
        n = len(self.name)
        for attr in ("model", "density_kg_m3", "youngs_modulus_pa", "poisson_ratio", "cohesion_pa",
                     "friction_deg", "dilation_deg", "tensile_strength_pa", "softening_law", "residual_cohesion_pa",
                     "residual_friction_deg", "softening_start_strain", "softening_end_strain"):
            dtype = np.int64 if attr in ("model", "softening_law") else np.float64
            raw = getattr(self, attr)
            empty = np.full(n, np.inf) if attr == "tensile_strength_pa" else np.zeros(n, dtype=dtype)
            value = empty if raw is None else np.ascontiguousarray(raw, dtype=dtype).reshape(-1)
            if value.shape != (n,):
                raise ValueError(f"MaterialTable.{attr}: expected {n} values, got {value.shape[0]}")
            object.__setattr__(self, attr, value)
        fits = ("",) * n if self.dp_fit is None else tuple(self.dp_fit)
        if len(fits) != n:
            raise ValueError(f"MaterialTable.dp_fit: expected {n} values, got {len(fits)}")
        object.__setattr__(self, "dp_fit", fits)

    @classmethod
    def elastic(cls, name: str, density_kg_m3: float, youngs_modulus_pa: float, poisson_ratio: float):
        """A table with a single linear elastic material."""
        return cls((name,), [MODEL_ELASTIC], [density_kg_m3], [youngs_modulus_pa], [poisson_ratio])

    @classmethod
    def single(cls, name, model, density_kg_m3, youngs_modulus_pa, poisson_ratio, cohesion_pa=0.0,
               friction_deg=0.0, dilation_deg=0.0, dp_fit=""):
        """A table with one material of ``model`` ("elastic", "drucker_prager", "mohr_coulomb")."""
        return cls((name,), [MODEL_NAMES[model]], [density_kg_m3], [youngs_modulus_pa], [poisson_ratio],
                   [cohesion_pa], [friction_deg], [dilation_deg], (dp_fit,))

    @property
    def n_materials(self) -> int:
        return len(self.name)

    @property
    def shear_modulus_pa(self) -> np.ndarray:
        """G = E / (2 (1 + nu))."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def bulk_modulus_pa(self) -> np.ndarray:
        """K = E / (3 (1 - 2 nu))."""
        return self.youngs_modulus_pa / (3.0 * (1.0 - 2.0 * self.poisson_ratio))

    @property
    def lame_lambda_pa(self) -> np.ndarray:
        """lambda = K - 2G/3."""
        return self.bulk_modulus_pa - 2.0 * self.shear_modulus_pa / 3.0

    @property
    def p_wave_speed_m_s(self) -> np.ndarray:
        """c_p = sqrt((K + 4G/3) / rho), the fastest wave of the material."""
        return np.sqrt((self.bulk_modulus_pa + 4.0 * self.shear_modulus_pa / 3.0) / self.density_kg_m3)

    def model_params(self) -> np.ndarray:
        """(n_mat, N_MODEL_PARAMS) constants the compiled update reads (see N_MODEL_PARAMS)."""
        params = np.zeros((self.n_materials, N_MODEL_PARAMS))
        params[:, 4] = self.tensile_strength_pa
        for m in range(self.n_materials):
            c, phi, psi = self.cohesion_pa[m], self.friction_deg[m], self.dilation_deg[m]
            if self.model[m] == MODEL_DRUCKER_PRAGER:
                if self.softening_law[m] != SOFTENING_NONE:
                    raise ValueError(f"MaterialTable: strain softening of material {self.name[m]!r} needs mohr_coulomb")
                fit = self.dp_fit[m] or default_dp_fit(psi, phi)
                params[m, :3] = dp_constants(c, phi, psi, fit)
            elif self.model[m] == MODEL_MOHR_COULOMB:
                params[m, :4] = (c, np.sin(np.radians(phi)), np.cos(np.radians(phi)), np.sin(np.radians(psi)))
                if self.softening_law[m] != SOFTENING_NONE:
                    if not self.softening_end_strain[m] > self.softening_start_strain[m] >= 0.0:
                        raise ValueError(f"MaterialTable: material {self.name[m]!r} needs 0 <= softening start < end")
                    params[m, 5:] = (self.residual_cohesion_pa[m], np.radians(self.residual_friction_deg[m]),
                                     np.radians(phi), self.softening_start_strain[m], self.softening_end_strain[m],
                                     self.softening_law[m])
        return params

    def with_strength_reduction(self, srf: float, associated: bool = False) -> "MaterialTable":
        """Strength divided by ``srf``: c_F = c / F, tan(phi_F) = tan(phi) / F, sigma_t,F = sigma_t / F
        (the tension cut-off falls with the cohesion), the residual strength alike, and psi_F = min(psi, phi_F), or psi_F = phi_F with
        ``associated`` (normality: the flow rule under which limit equilibrium and limit analysis give
        the factor of safety)."""
        if not srf > 0:
            raise ValueError(f"srf: must be > 0, got {srf}")
        phi_f = np.degrees(np.arctan(np.tan(np.radians(self.friction_deg)) / srf))
        psi_f = phi_f if associated else np.minimum(self.dilation_deg, phi_f)
        residual_phi_f = np.degrees(np.arctan(np.tan(np.radians(self.residual_friction_deg)) / srf))
        return replace(self, cohesion_pa=self.cohesion_pa / srf, friction_deg=phi_f, dilation_deg=psi_f,
                       tensile_strength_pa=self.tensile_strength_pa / srf,
                       residual_cohesion_pa=self.residual_cohesion_pa / srf, residual_friction_deg=residual_phi_f)

    def as_elastic(self) -> "MaterialTable":
        """The same table with every material linear elastic (e.g. for a gravity stage)."""
        return replace(self, model=np.full(self.n_materials, MODEL_ELASTIC, dtype=np.int64))


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
    wall_xy_m: np.ndarray | None = None  # (n_wall, 4) rigid segments (x1, y1, x2, y2); material on the left
    wall_friction: np.ndarray | None = None  # (n_wall,) Coulomb coefficient mu
    node_density_kg_m3: np.ndarray | None = None  # (n,) mass density per particle; default its material's
    node_load_n: np.ndarray | None = None  # (n, 2) constant forces on the particles (surface loads), N/m
    node_pore_pressure_pa: np.ndarray | None = None  # (n,) pore pressure carried by the particle (ru), Pa
    phreatic_lines_m: tuple = ()  # piezometric lines, each (n_points, 2) with x strictly increasing
    node_phreatic_line: np.ndarray | None = None  # (n,) int64 line of each particle in phreatic_lines_m; -1: none
    pond_level_m: float | None = None  # level of water standing on the ground surface (m)
    water_unit_weight_n_m3: float = 9810.0  # gamma_w

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
        walls = np.zeros((0, 4)) if self.wall_xy_m is None else self.wall_xy_m
        self.wall_xy_m = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        friction = np.zeros(self.wall_xy_m.shape[0]) if self.wall_friction is None else self.wall_friction
        self.wall_friction = np.ascontiguousarray(friction, dtype=np.float64).reshape(-1)
        if self.wall_friction.shape[0] != self.wall_xy_m.shape[0]:
            raise ValueError("Scene.wall_friction: one coefficient per wall expected")
        if not self.spacing_m > 0:
            raise ValueError(f"Scene.spacing_m: must be > 0, got {self.spacing_m}")
        for attr, shape in (("node_density_kg_m3", (n,)), ("node_load_n", (n, 2)), ("node_pore_pressure_pa", (n,))):
            value = getattr(self, attr)
            if value is not None:
                value = np.ascontiguousarray(value, dtype=np.float64).reshape(shape)
                if not np.all(np.isfinite(value)):
                    raise ValueError(f"Scene.{attr}: values must be finite")
                setattr(self, attr, value)
        if self.node_density_kg_m3 is not None and not np.all(self.node_density_kg_m3 > 0):
            raise ValueError("Scene.node_density_kg_m3: densities must be > 0")
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

    @property
    def particle_density_kg_m3(self) -> np.ndarray:
        """Mass density of every particle (n,): ``node_density_kg_m3`` or its material's."""
        if self.node_density_kg_m3 is not None:
            return self.node_density_kg_m3
        return self.materials.density_kg_m3[self.node_material]

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


@dataclass(frozen=True)
class SolverSettings:
    """Numerical parameters of a run (the physics lives in :class:`Scene`).

    Time step: ``dt_s`` if given, else ``cfl * dt_crit``, dt_crit = 2 / omega_bound with
    omega_bound a cell-by-cell bound on the highest frequency of the nodally integrated mesh
    (``spfem_core.timestep``; on a lattice it equals sqrt(h^2 / 2) / c_p).  A cfl (or a ``dt_s``
    equivalent to one) above ``timestep.max_stable_cfl(beta) = 1 / (1 + beta)`` is refused.

    ``stabilisation_beta`` scales the rank-deficiency correction (0 switches it off and
    its work is skipped).  The correction force is proportional to the incremental
    deformation error over one step, so it acts as a bond viscosity eta = beta E dt / 2:
    at fixed beta, halving dt halves the damping it applies to spurious modes.
    """

    cfl: float = 0.5
    dt_s: float | None = None
    stabilisation_beta: float = 0.0
    min_angle_deg: float = 20.0  # rebuild the mesh when the smallest angle falls below this (adaptive, see Simulation)
    crowded_fraction: float = 0.2  # after a rebuild, smooth particles closer than this * h to a neighbour
    threads: int = 0  # threads of the compiled step (0: all numba has, the cores); results do not depend on it
