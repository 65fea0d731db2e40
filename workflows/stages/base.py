"""What every stage kind is: its shared fields and the protocol the stage runner calls.

A stage kind is a module of this package (``dynamic``, ``relaxation``, ``runout``,
``strength_reduction``), one class built on :class:`StageBase`: its declaration (the fields of
``[[stages]]`` with ``kind = "<kind>"``), its checks within the study, what it sets before it
starts (:meth:`StageBase.materials`, :meth:`StageBase.acceleration_m_s2`, :meth:`StageBase.water`;
``workflows.stages.running.stage_setup`` puts them in the core's ``StageSetup``), how it runs
(:meth:`StageBase.run`), what it adds to its result file and figures, and its flags.  Like
pyro2's ``NullSimulation``, the base gives every method a default that a kind overrides.

The methods take what they work on as values (the simulation, the study, the study's water, the
result dataset): a stage kind is a declaration the study reader imports, so it imports no code that
runs (no scene, no water computed, no runner) and nothing heavy (numba, xarray) before anything is
compiled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from workflows.fields import Record, StudyError, boolean, name_field, names, number, text

ORIGINAL_POSITIONS = "original_positions"
CONTINUE = "continue"


RESERVED_STAGE_NAMES = frozenset({
    "summary", "study", "run", "seepage", "refinement", "probabilistic", "results", "report", "particle_spacing",
    "srf_curve", "fos_map", "pf", "pf_convergence", "fos_distribution", "convergence", "sensitivity",
})
"""Names of the files a study writes besides its stages' (``summary.nc``, ``results.pvd``, ...): a
stage of that name would write over one of them (a stage writes ``<name>.nc``, ``.gif``, ``.pvd``)."""
RESERVED_STAGE_PREFIXES = ("srf_", "fields_", "failed_")
"""Beginnings of the names of files a study writes per run (``srf_1.2000.nc``, ``fields_srf_1.2000.png``)."""


@dataclass(frozen=True, kw_only=True)
class StageBase(Record):
    """Fields shared by every kind of stage."""

    kind: ClassVar[str]
    duration_field: ClassVar[str]  # the field that bounds how long the stage runs
    animated: ClassVar[bool] = False  # [output] animation_interval_s draws it
    snapshotted: ClassVar[bool] = True  # [output] snapshot_interval_s writes ParaView files of it
    follows_runout: ClassVar[bool] = False  # it follows a failure to rest and measures its runout (one spacing,
    # its own metrics in a sweep's study.nc; not beside a strength reduction)
    name: str = name_field("name of the stage; names the result file when a study has several stages")
    record_interval_s: float = number("s", "time between two records of the monitors", gt=0.0)
    elastic: bool = boolean("treat every material as linear elastic in this stage (a gravity stage)", default=False)
    boundary: tuple | None = names("names of the [[boundary]] entries active in this stage; default: all", default=None)
    start: str = text(
        "`original_positions`: start at rest at the initial positions with the stresses the previous "
        "stage left (displacements discarded); `continue`: carry on from the previous stage's state",
        default=ORIGINAL_POSITIONS, choices=(ORIGINAL_POSITIONS, CONTINUE),
    )

    def check(self):
        if self.name.lower() in RESERVED_STAGE_NAMES or self.name.lower().startswith(RESERVED_STAGE_PREFIXES):
            raise StudyError("name", f"{self.name!r} is the name of a result file the study writes; choose another "
                             f"(not {', '.join(sorted(RESERVED_STAGE_NAMES))}, nor a name starting with "
                             f"{', '.join(RESERVED_STAGE_PREFIXES)})")
        if self.record_interval_s > self.time_limit_s:
            problem = f"must be <= {self.duration_field} = {self.time_limit_s:g}, got {self.record_interval_s:g}"
            raise StudyError("record_interval_s", problem)

    @property
    def time_limit_s(self) -> float:
        """The longest the stage runs (its ``duration_field``)."""
        return getattr(self, self.duration_field)

    # ------------------------------------------------------------------ in the study
    def check_in_study(self, study, index: int) -> None:
        """StudyError when the stage does not fit the study at position ``index`` (none by default)."""

    # ------------------------------------------------------------------ before it starts
    def materials(self, table):
        """The material table of the stage from the scene's (``spfem_core``'s ``MaterialTable``):
        linear elastic with ``elastic``, else as declared."""
        return table.as_elastic() if self.elastic else table

    def acceleration_m_s2(self, study) -> np.ndarray:
        """The body acceleration of the stage: gravity, with the seismic part where it acts before the
        strength reduction (``[loads.seismic] in_gravity``)."""
        return study.loads.acceleration_m_s2(study.geometry.polygon_m, strength_reduction=False)

    def water(self, study_water: tuple, study, node_material: np.ndarray) -> tuple:
        """(piezometric lines, line of each particle, pond level or None) of the stage, from the study's
        ``study_water`` (the same triple, ``workflows.water.pressure.study_water``): the study's."""
        return study_water

    # ------------------------------------------------------------------ running
    def run(self, sim, monitor_nodes: np.ndarray, *, progress=None, snapshot=None, next_starts_over: bool = False):
        """Run the stage on ``sim`` (a ``spfem_core.simulation.Simulation``, set up for it); its
        ``TimeSeries``.  ``next_starts_over``: the next stage starts from the original positions."""
        raise NotImplementedError(f"a {self.kind} stage has no run of its own")

    # ------------------------------------------------------------------ results
    def add_results(self, dataset, study, series, final) -> None:
        """Add the stage's own variables to its result dataset (an ``xarray.Dataset``) from its
        ``TimeSeries`` and final ``spfem_core.snapshot.Snapshot`` (none by default)."""

    def figures(self, study, result_path, out_dir) -> list:
        """Draw the stage's own figures from its result file into ``out_dir``; their paths (none by default)."""
        return []
