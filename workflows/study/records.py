"""What a study records and writes besides its stages' states: ``[[monitors]]``, ``[metrics]`` (the
collapse metrics of the last stage) and ``[output]`` (figures, snapshots, animations)."""

from __future__ import annotations

from dataclasses import dataclass

from workflows.collapse.kinds import COLLAPSE_KINDS, CollapseKind
from workflows.fields import Record, StudyError, boolean, name_field, number, text


@dataclass(frozen=True, kw_only=True)
class Monitor(Record):
    """A point whose nearest particle is recorded (displacement, velocity, stress)."""

    name: str = name_field("name of the monitor; the value of the monitor coordinate of the results")
    x_m: float = number("m", "x of the point, inside or on the polygon")
    y_m: float = number("m", "y of the point, inside or on the polygon")


@dataclass(frozen=True, kw_only=True)
class Metrics(Record):
    """Scalars computed from the final state of the last stage and stored in its result file."""

    kind: str = text("; ".join(f"`{name}`: {kind.description}" for name, kind in COLLAPSE_KINDS.items()),
                     choices=tuple(COLLAPSE_KINDS))
    moved_threshold_m: float = number(
        "m", "a particle whose displacement exceeds this has moved (failure line, back scarp)", gt=0.0
    )
    plastic_strain_threshold: float = number(
        "1", "equivalent plastic strain above which a particle counts in the plastic zone", default=0.01, gt=0.0
    )

    def check_in_study(self, study) -> None:
        """The metrics read a collapse: the last stage dynamic, a wall at x = 0 and a base at y = 0
        (``workflows.collapse.metrics``); ``granular_collapse`` compares with the experiment's column."""
        last = study.stages[-1]
        if last.kind != "dynamic":
            raise StudyError("metrics", f"collapse metrics read the final state of a dynamic stage; the last stage "
                             f"{last.name!r} is a {last.kind} stage")
        xs, ys = zip(*study.geometry.polygon_m)
        tolerance_m = 1e-3 * study.geometry.spacing_m
        if abs(min(xs)) > tolerance_m or abs(min(ys)) > tolerance_m:
            raise StudyError("metrics", f"collapse metrics measure from a wall at x = 0 and a base at y = 0; the "
                             f"domain starts at x = {min(xs):g} m, y = {min(ys):g} m")
        self.collapse.check_domain((max(xs) - min(xs), max(ys) - min(ys)), tolerance_m)

    @property
    def collapse(self) -> CollapseKind:
        """The kind of collapse ``kind`` names (``workflows.collapse.kinds``)."""
        return COLLAPSE_KINDS[self.kind]


MAX_SNAPSHOTS = 2000
"""A stage writes at most this many ParaView snapshots."""
MAX_ANIMATION_FRAMES = 1000
"""An animation has at most this many frames (they are kept in memory until the stage ends)."""


@dataclass(frozen=True, kw_only=True)
class Output(Record):
    """What is written beside the result files."""

    figures: bool = boolean(
        "draw PNG figures (a strength-reduction study: the SRF-displacement curve and the fields at the "
        "last stable and first failed SRF)", default=True,
    )
    snapshot_interval_s: float | None = number(
        "s", "write ParaView snapshots of every stage at this interval (`OUT/paraview/<stage>_<k>.vtu` and "
        "`<stage>.pvd`); SRF runs are not snapshotted (`python -m workflows.output.paraview OUT` gives their "
        "final states); default: none", default=None, gt=0.0,
    )
    animation_interval_s: float | None = number(
        "s", "draw an animation of every dynamic and runout stage, a frame per this interval of stage time "
        "(`OUT/<stage>.gif`, 10 frames per second); default: none", default=None, gt=0.0,
    )
    animation_colour: str = text(
        "what colours the particles of the animation", default="plastic_strain",
        choices=("plastic_strain", "displacement"),
    )

    def check_in_study(self, study) -> None:
        """Snapshots and animation frames within :data:`MAX_SNAPSHOTS` and :data:`MAX_ANIMATION_FRAMES`
        over the longest stage that writes them."""
        snapshotted = [s for s in study.stages if s.snapshotted]
        animated = [s for s in study.stages if s.animated]
        for name, limit, stages in (("snapshot_interval_s", MAX_SNAPSHOTS, snapshotted),
                                    ("animation_interval_s", MAX_ANIMATION_FRAMES, animated)):
            interval = getattr(self, name)
            longest = max((stage.time_limit_s for stage in stages), default=0.0)
            if interval is not None and longest / interval > limit:
                raise StudyError(f"output.{name}", f"{interval:g} s gives {longest / interval:.3g} frames over the "
                                 f"longest stage ({longest:g} s), more than {limit}")
