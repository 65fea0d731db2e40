"""What a FOS computed at one spacing carries: its expected discretisation excess, from the slopes on
which it was measured, said beside every FOS a study without ``[refinement]`` reports.

A study without ``[refinement]`` computes the FOS at its own spacing h.  The FOS converges to its
collapse value at first order from above (docs/method.md, section 9), so at h it lies above its
value at h -> 0 by an excess that grows with h and with the friction angle and steepness of the
slope.  ``MEASURED`` holds that excess at h = H / 10 on the published and test slopes of
docs/verification.md ("Error-controlled FOS", ``python -m verification.fos_accuracy``): each
slope's FOS at H/10 over its controlled FOS at h -> 0.  For a study of friction angle phi (the
largest of its materials'), the slopes within ``PHI_WINDOW_DEG`` of phi give the range of the
excess at H/10, scaled to the study's own H/h at first order: e(h) = e(H/10) * 10 h / H (at H/20 the
measured excesses are 0.3-0.6 of those at H/10).

Why a note and not a controlled FOS by default: the controlled FOS costs a study about twice the
runs of its first level on the quickstart, four to seven times at finer spacings, and as much for
every case of a sweep or realisation of a probabilistic study (docs/verification.md).  The note
says how large the error is expected to be and how to get the FOS at h -> 0 with its band.
"""

from __future__ import annotations

PHI_WINDOW_DEG = 5.0
"""Slopes whose friction angle lies within this of the study's give its expected excess."""

MEASURED = (
    # (slope, friction angle (deg), excess of its FOS at H/10 over the FOS at h -> 0)
    ("griffiths_lane_ex4", 0.0, 0.0024),
    ("taylor_53", 0.0, 0.0077),
    ("taylor_60", 0.0, 0.0074),
    ("taylor_75", 0.0, 0.0084),
    ("taylor_90", 0.0, 0.0258),
    ("phi10_2h1v", 10.0, 0.0024),
    ("acads_1a", 19.6, 0.0281),
    ("reference_slope", 20.0, 0.0162),
    ("verruijt_slope", 20.0, 0.0178),
    ("phi25_2h1v", 25.0, 0.0197),
    ("phi30_1.5h1v", 30.0, 0.0307),
    ("li_lumb_dry", 30.0, 0.0503),
    ("li_lumb_ru0.2", 30.0, 0.0592),
    ("phi35_1h1v", 35.0, 0.0599),
    ("phi35_0.5h1v", 35.0, 0.0877),
    ("phi40_1h1v", 40.0, 0.0586),
)
"""``python -m verification.fos_accuracy``: the column "excess at H/10" (phi35_0.5h1v: its level 0
over its f0, 1.4226 / 1.3079)."""


def friction_angle_deg(study) -> float:
    """The largest friction angle of the study's materials (0 for undrained and elastic ones)."""
    return max((float(getattr(material, "friction_deg", 0.0) or 0.0) for material in study.materials), default=0.0)


def expected_excess(study) -> tuple[float, float, int] | None:
    """(lowest, highest expected excess of the FOS at the study's spacing, slopes it rests on), or None
    where no measured slope lies near the study's friction angle."""
    phi = friction_angle_deg(study)
    near = [excess for _, angle, excess in MEASURED if abs(angle - phi) <= PHI_WINDOW_DEG]
    if not near:
        return None
    scale = 10.0 * study.geometry.finest_spacing_m / study.slope_height_m  # first order: e ~ h
    return min(near) * scale, max(near) * scale, len(near)


def note(study, what: str = "the FOS") -> str:
    """The line a FOS at one spacing gets (``what``: "the FOS", "each case's FOS"): its expected excess
    and how to control it."""
    per_height = study.slope_height_m / study.geometry.finest_spacing_m
    expected = expected_excess(study)
    if expected is None:
        size = "of a size not measured on slopes of this friction angle"
    else:
        low, high, count = expected
        size = (f"expected {100 * low:.1f}% to {100 * high:.1f}% above its value at h -> 0 (the excess at this "
                f"spacing on the {count} measured slope{'s' * (count > 1)} within {PHI_WINDOW_DEG:g} deg of phi = "
                f"{friction_angle_deg(study):g} deg)")
    return (f"discretisation not controlled: {what} at h = {study.geometry.finest_spacing_m:g} m (H/{per_height:.3g}) "
            f"lies above the collapse value, {size}; add [refinement] for the FOS at h -> 0 with its 95% band "
            "(docs/method.md, section 9)")
