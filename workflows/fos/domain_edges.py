"""Where the box, not the soil, decides: the supports a failure mechanism reaches.

A support (``[[boundary]]`` of the strength-reduction stage) is reached when at least
``MIN_CONTACT`` particles of the mechanism lie within ``REACH`` spacings of its particles (each
particle's own spacing), or when the slip line's entry or exit (where the mechanism comes out on the
ground) lies within ``REACH`` spacings of one of them: a back scarp at a side holds few particles
between the line and the ground, fewer than ``MIN_CONTACT`` at a coarse spacing.  The mechanism is the
first failed run's shear band and the soil it bounds (``slip_surface``: the band of plastic strain, and
the particles above the line through it).  Each support reached is named with what it is and what to do:

- a side (a support on a vertical line at the domain's left or right end, behind the crest or beyond
  the toe): the domain is too short there; widen it;
- a welded support (both directions held, no sliding): the soil cannot slide along it, which holds
  the mechanism up; let it slide (leave out ``slip = "welded"``) or move it away;
- a smooth base (the normal direction held, the tangent free): the soil slides along it with no
  resistance; make it rough or deepen the domain;
- a rough base (a slip support at the bottom): the mechanism slides along it at the soil's strength,
  right where the base is a firm stratum; deepen the domain where the ground goes on below it.

The first three are warnings (the answer depends on where the box was drawn); the last is a note.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from spfem_core.geometry import surface_height_m
from workflows.fos.slip_surface import band_line, moving_mass, shear_band
from workflows.scene import slip_normal

MIN_CONTACT = 3
"""A support is reached by at least this many particles of the mechanism."""
REACH = 1.5
"""... within this many spacings of one of its particles."""
SIDE, WELDED, SMOOTH_BASE, ROUGH_BASE, OTHER = "side", "welded", "smooth base", "rough base", "support"


@dataclass(frozen=True)
class EdgeContact:
    """A support the mechanism reaches."""

    support: str  # its [[boundary]] name
    kind: str  # SIDE, WELDED, SMOOTH_BASE, ROUGH_BASE or OTHER
    where: str  # e.g. "the side x = 0 m, behind the crest"
    particles: int  # particles of the mechanism at it
    advice: str

    @property
    def warning(self) -> bool:
        """The box decides: the answer depends on where the support was drawn."""
        return self.kind != ROUGH_BASE

    @property
    def line(self) -> str:
        return f"the mechanism reaches {self.where} ({self.support!r}, {self.particles} particles): {self.advice}"


def _support_kind(study, boundary, xy0: np.ndarray, nodes: np.ndarray, spacing_m: float) -> tuple[str, str, str]:
    """(kind, where, advice) of a support (module doc)."""
    normal = slip_normal(xy0, spacing_m, boundary, nodes)
    both = boundary.vx_m_s is not None and boundary.vy_m_s is not None
    x, y = xy0[nodes, 0], xy0[nodes, 1]
    tol = 1e-3 * spacing_m
    x_min, x_max, y_min = xy0[:, 0].min(), xy0[:, 0].max(), xy0[:, 1].min()
    crest_left = _crest_on_the_left(study)
    if both and normal is None:
        return (WELDED, f"the welded support {boundary.name!r}",
                "the soil cannot slide along it, which holds the mechanism up: let it slide (leave out "
                "slip = \"welded\") or move it away from the slope")
    if np.ptp(x) <= tol and (abs(x.mean() - x_min) <= tol or abs(x.mean() - x_max) <= tol):
        left = abs(x.mean() - x_min) <= tol
        side = "behind the crest" if left == crest_left else "beyond the toe"
        return (SIDE, f"the side x = {x.mean():.4g} m, {side}",
                f"the domain is too short {side}: widen it (move this side further from the slope) until the "
                "mechanism stays clear of it")
    if np.ptp(y) <= tol and abs(y.mean() - y_min) <= tol:
        if normal is None:
            return (SMOOTH_BASE, f"the smooth base y = {y.mean():.4g} m",
                    "the soil slides along it with no resistance: make it rough (vx_m_s = vy_m_s = 0, or "
                    "slip = \"soil\") or deepen the domain")
        return (ROUGH_BASE, f"the base y = {y.mean():.4g} m",
                "it slides along the base at the soil's strength: right if the base is a firm stratum; if the ground "
                "goes on below it, deepen the domain")
    return (OTHER, f"the support {boundary.name!r}", "check that the support stands for something real at this place")


def _crest_on_the_left(study) -> bool:
    """Whether the ground is higher at the domain's left end than at its right end."""
    polygon = np.asarray(study.geometry.polygon_m, dtype=float)
    ends = surface_height_m(polygon, np.array([polygon[:, 0].min(), polygon[:, 0].max()]))
    return bool(ends[0] >= ends[1])


def mechanism_particles(failed: dict, stable: dict | None) -> np.ndarray:
    """(n,) bool: the mechanism of the first failed run (module doc), from its particle fields and those
    of the last stable run (dicts of arrays as ``slip_surface.run_particles`` gives: x0, y0, ux, uy,
    spacing, and plastic_strain when kept): its shear band and the particles above the band's line, or
    without plastic strain the moving mass of its displacements."""
    xy0 = np.column_stack([failed["x0"], failed["y0"]])
    spacing = np.asarray(failed["spacing"], dtype=float)
    band = shear_band(failed, stable)
    if band is not None:
        polygon = np.array([[xy0[:, 0].min(), xy0[:, 1].min()], [xy0[:, 0].max(), xy0[:, 1].min()],
                            [xy0[:, 0].max(), xy0[:, 1].max()], [xy0[:, 0].min(), xy0[:, 1].max()]])
        x, y = band_line(xy0, *band, spacing, polygon)
        above = (xy0[:, 1] > np.interp(xy0[:, 0], x, y)) & (xy0[:, 0] >= x[0]) & (xy0[:, 0] <= x[-1])
        return band[0] | above
    ux, uy = failed["ux"], failed["uy"]
    if stable is not None:
        ux, uy = ux - stable["ux"], uy - stable["uy"]
    displacement = np.hypot(ux, uy)
    if np.count_nonzero(displacement > 0.0) < 10:
        return np.zeros(xy0.shape[0], dtype=bool)
    return moving_mass(xy0, displacement, float(np.max(spacing)))[0]


def edge_contacts(study, failed: dict, stable: dict | None, slip_line_m=None) -> list[EdgeContact]:
    """The supports of the strength-reduction stage that the mechanism reaches (module doc);
    ``slip_line_m``: (x, y) of its slip line from entry to exit, or None."""
    xy0 = np.column_stack([failed["x0"], failed["y0"]])
    spacing = np.asarray(failed["spacing"], dtype=float)
    members = mechanism_particles(failed, stable)
    if not members.any():
        return []
    h = float(np.min(spacing))
    active = study.strength_reduction.boundary
    tree = cKDTree(xy0[members])
    ends = np.empty((0, 2))
    if slip_line_m is not None and len(slip_line_m[0]):
        x, y = np.asarray(slip_line_m[0], dtype=float), np.asarray(slip_line_m[1], dtype=float)
        ends = np.array([[x[0], y[0]], [x[-1], y[-1]]])
    contacts = []
    for boundary in study.boundary:
        if active is not None and boundary.name not in active:
            continue
        nodes = np.flatnonzero(boundary.holds(xy0, h))
        if nodes.size == 0:
            continue
        near = tree.query_ball_point(xy0[nodes], REACH * spacing[nodes])
        touching = np.unique(np.concatenate([np.asarray(each, dtype=np.int64) for each in near]))
        end_at_it = any(np.any(np.hypot(*(xy0[nodes] - end).T) <= REACH * spacing[nodes]) for end in ends)
        if touching.size >= MIN_CONTACT or end_at_it:
            kind, where, advice = _support_kind(study, boundary, xy0, nodes, h)
            contacts.append(EdgeContact(boundary.name, kind, where, int(touching.size), advice))
    return contacts
