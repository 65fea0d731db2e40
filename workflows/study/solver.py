"""``[solver]``: the time step, the stabilisation and the alpha shape of the mesh."""

from __future__ import annotations

from dataclasses import dataclass

from spfem_core.settings import DEFAULT_ALPHA, DEFAULT_CFL, DEFAULT_MIN_ANGLE_DEG, DEFAULT_STABILISATION_BETA
from workflows.fields import Record, StudyError, boolean, number


@dataclass(frozen=True, kw_only=True)
class Solver(Record):
    """Numerical settings: time step, stabilisation and the alpha-shape of the mesh."""

    cfl: float | None = number(
        "1", f"time step as a fraction of the critical step; default {DEFAULT_CFL} when dt_s is not given",
        default=None, gt=0.0, le=1.0,
    )
    dt_s: float | None = number(
        "s", "fixed time step instead of cfl; refused if above the stable step, the critical step / (1 + beta)", default=None, gt=0.0
    )
    stabilisation_beta: float = number(
        "1", "rank-deficiency stabilisation factor beta; 0 switches it off (a relaxation of elastic materials, a "
        "gravity stage, runs without it: the bonds vanish at rest)", default=DEFAULT_STABILISATION_BETA, ge=0.0
    )
    alpha: float = number(
        "1", "alpha-shape factor: triangles with circumradius > alpha h are dropped", default=DEFAULT_ALPHA, ge=1.0,
        le=3.0,
    )
    remesh_min_angle_deg: float = number(
        "degree", "rebuild the mesh when its smallest angle falls below this; after each rebuild the "
        "threshold is the fresh mesh's smallest angle less 5 degrees (or half of it, if that is larger), "
        "never above this", default=DEFAULT_MIN_ANGLE_DEG, gt=0.0, lt=60.0,
    )
    density_scaling: bool = boolean(
        "with [[geometry.refined]] zones: relaxations (gravity, quasi-static SRF runs) scale the fine particles' "
        "inertia to step at the coarse particles' critical step; the fine zone then responds slower in "
        "pseudo-time (give longer durations); measured no faster where the mechanism is refined "
        "(docs/method.md, section 5)", default=False,
    )
    uniform_relaxation_step: bool = boolean(
        "relaxations (gravity, quasi-static SRF runs) give the few particles whose cells hold the stable step "
        "down (at the free surface) more inertia, so that no cell steps below the median cell: about half the "
        "steps to the same end state (docs/method.md, section 5); false: every particle's inertia is its mass",
        default=True,
    )

    def check(self):
        if self.cfl is not None and self.dt_s is not None:
            raise StudyError("dt_s", "give cfl or dt_s, not both")
