"""The arrays the compiled time loop works on, grouped by what they describe.

Named tuples of arrays and scalars: numba compiles attribute access to the same code as
separate arguments, and :func:`spfem_core.stepper.advance` gets a signature a reader can
follow.  All arrays are float64, int64 or bool, C-contiguous, SI units; vectors are (n, 2),
the plane-strain stress is (n, 4) ordered (xx, yy, zz, xy), tension positive, and the velocity
gradient (n, 4) ordered (xx, xy, yx, yy): the kernels and the Python around them name the
components (:data:`XX` ... :data:`XY`, :data:`L_XX` ... :data:`L_YY`, module-level integers that
numba compiles as constants) instead of numbering them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

LEAPFROG_OUT = ("max_speed_sq", "unbalanced_force_sq", "applied_force_sq", "damping_power", "contact_loss",
                "contacts")
"""Slots of ``StepScratch.leapfrog_out``, filled by ``integration.leapfrog`` every step: the largest
speed squared (m^2/s^2; NaN if any speed is NaN), |f_unbalanced|^2 and |m g|^2 on the free directions
(N^2/m^2), the damping power (W/m, <= 0), the energy the walls and slip supports removed (J/m), the particles touching
a wall."""
(LEAPFROG_MAX_SPEED_SQ, LEAPFROG_UNBALANCED_FORCE_SQ, LEAPFROG_APPLIED_FORCE_SQ, LEAPFROG_DAMPING_POWER,
 LEAPFROG_CONTACT_LOSS, LEAPFROG_CONTACTS) = range(len(LEAPFROG_OUT))
LEAPFROG_OUT_WIDTH = len(LEAPFROG_OUT)

STRESS = ("xx", "yy", "zz", "xy")
"""Components of a plane-strain stress row (``NodeState.stress_pa``, Pa, tension positive; zz out of
the plane, where the strain is zero)."""
XX, YY, ZZ, XY = range(len(STRESS))
STRESS_WIDTH = len(STRESS)

VELOCITY_GRADIENT = ("xx", "xy", "yx", "yy")
"""Components of a smoothed velocity gradient row (``StepScratch.velocity_gradient``, 1/s):
L_ab = d v_a / d x_b, row by row."""
L_XX, L_XY, L_YX, L_YY = range(len(VELOCITY_GRADIENT))
VELOCITY_GRADIENT_WIDTH = len(VELOCITY_GRADIENT)

SLIP = ("cohesion_n_m", "tan_friction", "side")
"""Columns of ``NodeState.slip``: c L_k (N per m of thickness), tan(phi), and the side s = +-1 the support
lies on along the particle's prescribed direction (0: not a slip support, the default)."""
SLIP_COHESION, SLIP_FRICTION, SLIP_SIDE = range(len(SLIP))


class NodeState(NamedTuple):
    """Per-particle state, carried from step to step (and stage to stage)."""

    xy_m: np.ndarray  # (n, 2) current positions
    displacement_m: np.ndarray  # (n, 2) since the particles last left their initial positions
    velocity_m_s: np.ndarray  # (n, 2) leapfrog half-step velocity
    stress_pa: np.ndarray  # (n, 4) Cauchy stress, columns STRESS
    plastic_strain: np.ndarray  # (n,) equivalent plastic strain, sum of sqrt(2/3 de_p:de_p)
    mass_kg: np.ndarray  # (n,) per metre of thickness, fixed at the start: m_k = rho_k A_k
    inertia_kg: np.ndarray  # (n,) the mass that the force accelerates: m_k, or density-scaled (simulation.relax)
    material_row: np.ndarray  # (n,) int64 row of the simulation's material table (its material's, or its own)
    fixed: np.ndarray  # (n, 2) bool: velocity prescribed in that direction
    fixed_velocity_m_s: np.ndarray  # (n, 2) the prescribed velocity where ``fixed``
    slip: np.ndarray  # (n, 3) slip supports, columns ``SLIP`` (integration.leapfrog); side 0 everywhere: none


class StepScratch(NamedTuple):
    """Arrays every step recomputes; their last values describe the current mesh."""

    velocity_gradient: np.ndarray  # (n, 4) smoothed L_k, columns VELOCITY_GRADIENT, 1/s
    area_m2: np.ndarray  # (n,) smoothing-cell area A_k
    force_n: np.ndarray  # (n, 2) f_int + f_stab per metre of thickness
    contact: np.ndarray  # (n,) int64, 1 where a wall acted in the last step
    leapfrog_out: np.ndarray  # (LEAPFROG_OUT_WIDTH,) the slots of LEAPFROG_OUT
    pore_pressure_pa: np.ndarray  # (n,) u_k of the last step (compression positive); 0 without water
    external_force_n: np.ndarray  # (n, 2) water and surface-load forces of the last step (``external_forces``)

    @classmethod
    def for_nodes(cls, n: int) -> StepScratch:
        """Scratch for ``n`` particles."""
        return cls(np.zeros((n, VELOCITY_GRADIENT_WIDTH)), np.zeros(n), np.zeros((n, 2)), np.zeros(n, dtype=np.int64),
                   np.zeros(LEAPFROG_OUT_WIDTH), np.zeros(n), np.zeros((n, 2)))


class MeshArrays(NamedTuple):
    """The current mesh as the kernels read it (``mesh.Mesh``: triangles, bonds, CSR adjacency, blocks)."""

    elem_nodes: np.ndarray  # (n_elem, 3) int64, counter-clockwise, in the order of their lowest node
    node_elem_ptr: np.ndarray  # (n + 1,) int64
    node_elem_idx: np.ndarray  # (3 n_elem,) int64 elements of each node, ascending
    edge_nodes: np.ndarray  # (n_edges, 2) int64, (i, j) with i < j, in the order of i
    node_node_ptr: np.ndarray  # (n + 1,) int64
    node_node_idx: np.ndarray  # (2 n_edges,) int64 neighbours of each node, ascending
    elem_block_ptr: np.ndarray  # (n_blocks + 1,) int64 element blocks (mesh.coloured_blocks)
    elem_colour_ptr: np.ndarray  # (n_colours + 1,) int64
    elem_colour_block: np.ndarray  # (n_blocks,) int64 blocks colour by colour: one colour's share no node
    edge_block_ptr: np.ndarray  # the same three for the edges
    edge_colour_ptr: np.ndarray
    edge_colour_block: np.ndarray


class MaterialArrays(NamedTuple):
    """The constants of the material rows the kernels read (``materials.table.MaterialTable``)."""

    model: np.ndarray  # (n_rows,) int64 code of the row's model (materials.MODELS)
    lame_lambda_pa: np.ndarray  # (n_rows,)
    shear_modulus_pa: np.ndarray  # (n_rows,)
    youngs_modulus_pa: np.ndarray  # (n_rows,)
    poisson_ratio: np.ndarray  # (n_rows,)
    params: np.ndarray  # (n_rows, width) each model's named constants (MaterialTable.kernel_constants)


class Walls(NamedTuple):
    """Rigid segments (``contact`` module doc)."""

    xy_m: np.ndarray  # (n_wall, 4) x1, y1, x2, y2; material on the left of 1 -> 2
    friction: np.ndarray  # (n_wall,) Coulomb coefficient mu


class ExternalLoads(NamedTuple):
    """Forces on the soil skeleton besides gravity and its effective stress (``external_forces``).

    ``active`` False skips all of them (a dry, unloaded scene pays nothing).
    """

    active: bool
    node_force_n: np.ndarray  # (n, 2) constant forces carried by the particles (surface loads), N/m
    node_pore_pressure_pa: np.ndarray  # (n,) pore pressure carried by the particle (ru), Pa
    phreatic_xy_m: np.ndarray  # (n_points, 2) the piezometric lines one after another, x increasing in each
    phreatic_start: np.ndarray  # (n_lines + 1,) int64: line i is phreatic_xy_m[start[i]:start[i + 1]]
    node_phreatic_line: np.ndarray  # (n,) int64 line of each particle; -1: none (no pore pressure from a line)
    water_unit_weight_n_m3: float  # gamma_w
    pond_level_m: float  # level of water standing on the surface; NaN: none
    pond_x_range_m: np.ndarray  # (2,) the pond loads boundary edges whose midpoint x lies in [x_min, x_max]
    boundary_edges: np.ndarray  # (n_edges, 2) int64 edges of the current mesh's boundary, material on the left
    at_initial_positions: bool  # water pressures from x - u (a gravity stage, whose displacement is discarded)
    ramp_time_s: float  # the surface loads grow as min(t / ramp_time_s, 1) over the stage time t; 0: at once


class StepParameters(NamedTuple):
    """Scalars of the explicit step (fixed within one compiled call)."""

    gravity_m_s2: np.ndarray  # (2,)
    dt_s: float
    damping: float  # local (Cundall) damping factor xi
    beta: float  # stabilisation factor; 0 skips the bond loop
    spacing_m: float  # nominal particle spacing h: wall reach, shortest stabilisation bond h/2
    speed_limit_m_s: float  # divergence: a particle faster than this
    tolerance: float  # relaxation: stop when the unbalanced-force ratio is below it (0: never)
    angle_threshold_rad: float  # rebuild the mesh when its smallest angle falls below this
    angle_margin_rad: float  # safety margin of the cheap angle bound
    n_threads: int | None  # jit.kernel_threads: None, plain loops (the threaded code is not compiled); else threads
    inertia_is_mass: bool  # the leapfrog reads no inertia, and slip rows only on the slip supports (integration)
