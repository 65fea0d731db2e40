"""The numerical settings of a run and their defaults (no numba: the study reader imports them).

The defaults are the constants below; the study file's ``[solver]`` table documents and reads
the same constants (``workflows.study.tables.Solver``), so a core user and a study-file user get
the same run when they leave a setting out.
"""

from __future__ import annotations

from dataclasses import dataclass

DEFAULT_CFL = 0.5
"""Time step as a fraction of the critical step (``timestep``)."""

DEFAULT_STABILISATION_BETA = 0.1
"""Rank-deficiency stabilisation factor (``stabilisation``): the value the beam, the collapses and
the published slopes were verified with."""

DEFAULT_MIN_ANGLE_DEG = 20.0
"""Rebuild the mesh when its smallest angle falls below this (the ceiling of the adaptive threshold, ``remeshing``)."""

DEFAULT_CROWDED_FRACTION = 0.2
"""After a rebuild, smooth the particles closer than this times h to a neighbour (``remeshing``)."""

DEFAULT_ALPHA = 1.5
"""Alpha-shape factor: a triangle whose circumradius exceeds alpha h is dropped (``mesh``)."""


@dataclass(frozen=True)
class SolverSettings:
    """Numerical parameters of a run (the physics lives in ``scene.Scene``).

    Time step: ``dt_s`` if given, else ``cfl * dt_crit``, dt_crit = 2 / omega_bound with
    omega_bound a cell-by-cell bound on the highest frequency of the nodally integrated mesh
    (``spfem_core.timestep``; on a lattice it equals sqrt(h^2 / 2) / c_p).  A cfl (or a ``dt_s``
    equivalent to one) above ``timestep.max_stable_cfl(beta) = 1 / (1 + beta)`` is refused.

    ``stabilisation_beta`` scales the rank-deficiency correction (0 switches it off and
    its work is skipped); a relaxation of elastic materials runs without it
    (``Simulation.beta``).  The correction force is proportional to the incremental
    deformation error over one step, so it acts as a bond viscosity eta = beta E dt / 2:
    at fixed beta, halving dt halves the damping it applies to spurious modes.
    """

    cfl: float = DEFAULT_CFL
    dt_s: float | None = None
    stabilisation_beta: float = DEFAULT_STABILISATION_BETA
    min_angle_deg: float = DEFAULT_MIN_ANGLE_DEG  # rebuild the mesh when the smallest angle falls below this
    crowded_fraction: float = DEFAULT_CROWDED_FRACTION  # after a rebuild, smooth particles closer than this * h
    threads: int = 0  # threads of the compiled step (0: all numba has, the cores); results do not depend on it
    density_scaling: bool = False  # relaxations of a graded cloud at the coarse particles' step (Simulation.relax)
    uniform_relaxation_step: bool = True  # relaxations with no cell's step below the median cell's (Simulation.relax)
