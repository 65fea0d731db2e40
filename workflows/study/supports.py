"""``[[boundary]]`` and ``[[walls]]``: what holds the body, prescribed velocities in a box and rigid
walls with friction."""

from __future__ import annotations

from dataclasses import dataclass

from workflows.box import Box
from workflows.fields import Record, StudyError, name_field, number, point, text


class Slip:
    """How the soil moves along a support (``[[boundary]] slip``; the class doc of :class:`Boundary`)."""

    def check(self, boundary) -> None:
        """StudyError naming ``slip`` where the support's velocities do not fit this kind; none by default."""

    def held_direction(self, boundary, line_normal: int | None) -> int | None:
        """The direction a slip support holds (0: x, 1: y), or None for a support that is not one;
        ``line_normal`` is the direction across the straight horizontal or vertical line the support's
        particles lie on (None: they lie on no such line)."""
        return None


class FreeSlip(Slip):
    """``slip = "none"``: the directions not prescribed are free (a smooth roller)."""


class WeldedSlip(Slip):
    """``slip = "welded"``: both directions held, no sliding."""

    def check(self, boundary) -> None:
        if None in (boundary.vx_m_s, boundary.vy_m_s):
            raise StudyError("slip", "a welded support prescribes both directions: give vx_m_s and vy_m_s")


class SoilSlip(Slip):
    """``slip = "soil"``: held at 0 across the support, sliding along it at the soil's strength."""

    def check(self, boundary) -> None:
        if boundary.vx_m_s or boundary.vy_m_s:
            raise StudyError("slip", "a slip support holds its prescribed direction at 0 m s-1")

    def held_direction(self, boundary, line_normal: int | None) -> int | None:
        """The one direction prescribed; with both prescribed at 0, the one across its line (StudyError
        where its particles lie on none)."""
        if [boundary.vx_m_s, boundary.vy_m_s].count(None) == 1:
            return 0 if boundary.vx_m_s is not None else 1
        if not boundary.holds_both_at_rest:
            return None
        if line_normal is not None:
            return line_normal
        raise StudyError("boundary", f"the slip support {boundary.name!r} holds both velocities, so its particles "
                         "must lie on one horizontal or vertical line (the direction it holds is the one across it); "
                         "they do not: give only the velocity it holds (vx_m_s or vy_m_s = 0), or slip = \"welded\"")


class RoughBaseSlip(Slip):
    """``slip`` left out: a support that holds both velocities at 0 along one horizontal or vertical
    line slips as ``soil`` does (a rough rigid base); any other is not a slip support."""

    def held_direction(self, boundary, line_normal: int | None) -> int | None:
        return line_normal if boundary.holds_both_at_rest else None


SLIP_KINDS: dict[str | None, Slip] = {None: RoughBaseSlip(), "none": FreeSlip(), "soil": SoilSlip(),
                                      "welded": WeldedSlip()}
"""Every kind of support, by the value of ``slip`` (None: left out)."""


@dataclass(frozen=True, kw_only=True)
class Boundary(Box):
    """Prescribed velocity on the particles initially inside a box (closed, tolerance h/1000).

    A missing bound leaves the box open on that side; a missing velocity leaves that
    direction free (vx = 0 alone is a roller).  A support that holds both velocities at 0 along
    one straight horizontal or vertical line is rough by default (``slip = "soil"``): held across
    the line, the soil sliding along it at its own strength (docs/method.md, section 3), as a rigid
    rough base lets it; ``slip = "welded"`` holds both directions instead.
    """

    name: str = name_field("name of the boundary condition")
    vx_m_s: float | None = number("m s-1", "prescribed x velocity; default: free", default=None)
    vy_m_s: float | None = number("m s-1", "prescribed y velocity; default: free", default=None)
    slip: str | None = text(
        "how the soil moves along the support: `soil`: held at 0 across it, sliding along it once its shear force "
        "passes the soil's strength, c + sigma_n tan(phi) (reduced by the SRF) over each particle's share of the "
        "support: a firm rough base; `welded`: both directions held, no sliding; `none`: the directions not "
        "prescribed are free (a smooth roller). Default: `soil` for a support that holds both velocities at 0 "
        "along one straight horizontal or vertical line of particles (a rough rigid base), `none` otherwise",
        default=None, choices=tuple(name for name in SLIP_KINDS if name is not None),
    )

    def check(self):
        if self.vx_m_s is None and self.vy_m_s is None:
            raise StudyError("vx_m_s", "give vx_m_s, vy_m_s or both (a boundary must prescribe something)")
        self.slip_kind.check(self)
        super().check()

    @property
    def slip_kind(self) -> Slip:
        """How the soil moves along it (:data:`SLIP_KINDS`)."""
        return SLIP_KINDS[self.slip]

    @property
    def holds_both_at_rest(self) -> bool:
        """Both velocities prescribed at 0: a rigid support, rough unless ``slip`` says otherwise."""
        return self.vx_m_s == 0.0 and self.vy_m_s == 0.0


@dataclass(frozen=True, kw_only=True)
class Wall(Record):
    """A rigid wall: a straight segment with Coulomb friction; material lies on its left
    when going from start to end (a floor runs in +x)."""

    name: str = name_field("name of the wall")
    start_m: tuple[float, float] = point("m", "first end of the segment [x, y]")
    end_m: tuple[float, float] = point("m", "second end of the segment [x, y]")
    friction: float = number("1", "Coulomb friction coefficient mu (0: frictionless)", default=0.0, ge=0.0)

    def check(self):
        if self.start_m == self.end_m:
            raise StudyError("end_m", "must differ from start_m (a wall needs a length)")
