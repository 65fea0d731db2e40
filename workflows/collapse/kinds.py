"""The kinds of collapse ``[metrics] kind`` names, each with its behaviour: the domain it can
measure and the scalars it computes on a stage's final particles (``workflows.output.metrics``).

A kind is one object of :data:`COLLAPSE_KINDS`, by the name the study file gives; its scalars
are ``workflows.collapse.metrics``'s (scipy: imported by the method that computes them, never
by the study reader)."""

from __future__ import annotations

from workflows.collapse.experiment import GRANULAR_COLUMN_M
from workflows.fields import StudyError


class CollapseKind:
    """One kind of collapse metrics."""

    name: str
    description: str  # what it computes, for the study-file reference

    def check_domain(self, size_m: tuple[float, float], tolerance_m: float) -> None:
        """StudyError where the domain (length, height) is not one this kind measures; any by default."""

    def summary(self, metrics, xy, xy0, spacing_m: float, area_m2, plastic_strain) -> dict[str, float]:
        """The scalars on the meshed particles (final ``xy`` and initial ``xy0`` positions, m), with the
        thresholds of ``metrics`` (the study's ``[metrics]``)."""
        raise NotImplementedError


class GranularCollapse(CollapseKind):
    """The granular column of Bui et al. (2008), compared with the experiment's deposit."""

    name = "granular_collapse"
    description = ("wall height, runouts, surface RMS error against the Bui et al. (2008) experiment, "
                   "failure-line angle")

    def check_domain(self, size_m, tolerance_m) -> None:
        """The experiment's column, to ``tolerance_m``."""
        if not all(abs(a - b) <= tolerance_m for a, b in zip(size_m, GRANULAR_COLUMN_M)):
            raise StudyError("metrics.kind", "granular_collapse compares the deposit with the Bui et al. (2008) "
                             f"experiment, a {GRANULAR_COLUMN_M[0]:g} x {GRANULAR_COLUMN_M[1]:g} m column; this "
                             f"domain is {size_m[0]:g} x {size_m[1]:g} m")

    def summary(self, metrics, xy, xy0, spacing_m, area_m2, plastic_strain) -> dict[str, float]:
        from workflows.collapse.metrics import granular_summary  # scipy: only when measured

        return granular_summary(xy, xy0, spacing_m, moved_threshold_m=metrics.moved_threshold_m)


class CohesiveCollapse(CollapseKind):
    """A cohesive column or slope collapsing against a wall."""

    name = "cohesive_collapse"
    description = "back scarp, crest height, toe, plastic zone"

    def summary(self, metrics, xy, xy0, spacing_m, area_m2, plastic_strain) -> dict[str, float]:
        from workflows.collapse.metrics import cohesive_summary  # scipy: only when measured

        return cohesive_summary(xy, xy0, spacing_m, area_m2, plastic_strain,
                                moved_threshold_m=metrics.moved_threshold_m,
                                plastic_strain_threshold=metrics.plastic_strain_threshold)


COLLAPSE_KINDS: dict[str, CollapseKind] = {kind.name: kind for kind in (GranularCollapse(), CohesiveCollapse())}
"""Every kind of collapse metrics, by its name in the study file."""
