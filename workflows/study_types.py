"""The kinds of study, and the one way to run any of them.

A study type (``workflows.cases.StudyType``) makes its cases, says how they run (its
``Placement``), and brings their outcomes together:

- ``single.SingleStudy``: a study without ``[sweep]``, one case in the output folder;
- ``sweep.study_type.SweepStudy``: a study with ``[sweep]``, a case per combination of the
  axes' values, and ``study.nc``;
- ``refinement.study_type.RefinementStudy``: a study with ``[refinement]``, a case per particle
  spacing, each after the one before (rounds: ``StudyType.next_cases``), and ``refinement.nc``;
- ``refinement.sweep.RefinedSweepStudy``: a study with both, a refinement study per case of the
  sweep, their levels advancing together round by round, and ``study.nc``.

- ``probabilistic.study_type.ProbabilisticStudy``: a study with ``[probabilistic]``, a case per
  realisation of its random variables (run as a sweep's), and ``probabilistic.nc`` with pf;
- ``probabilistic.design_points.DesignPointStudy``: ``[probabilistic]`` with ``method = "form"`` or
  ``"point_estimate"``, a case per point it places (FORM's iterations in rounds), and ``probabilistic.nc``
  with beta or the FOS's moments;
- ``probabilistic.subset_study.SubsetStudy``: ``method = "subset_simulation"``, level after level of
  Markov chains on the FOS (rounds), and ``probabilistic.nc`` with pf and its coefficient of variation;
- ``probabilistic.sweep.ProbabilisticSweepStudy``: a study with both ``[sweep]`` and
  ``[probabilistic]``, a probabilistic study per case, every realisation on one cluster, and
  ``study.nc`` with pf per case.

:func:`run_study` asks the study for its type once, checks it, makes its cases, computes them
with the one case runner (``workflows.cases.run_cases``), round after round while the type makes
more, and concludes.
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from pathlib import Path

from workflows.cases import RunOptions, StudyType, run_cases
from workflows.output.folder_lock import folder_lock, study_digest
from workflows.probabilistic.design_points import DesignPointStudy
from workflows.probabilistic.study_type import ProbabilisticStudy
from workflows.probabilistic.subset_study import SubsetStudy
from workflows.probabilistic.sweep import ProbabilisticSweepStudy
from workflows.progress import Progress
from workflows.refinement.study_type import RefinementStudy
from workflows.refinement.sweep import RefinedSweepStudy
from workflows.single import SingleStudy
from workflows.study import Study
from workflows.sweep.study_type import SweepStudy

STUDY_TYPES: tuple[type[StudyType], ...] = (ProbabilisticSweepStudy, SubsetStudy, DesignPointStudy,
                                              ProbabilisticStudy, RefinedSweepStudy, RefinementStudy, SweepStudy,
                                              SingleStudy)
"""Every study type, asked in this order whether a study is of it (the last takes any study)."""


def study_type(study: Study, out_dir: str | Path) -> StudyType:
    """The type of ``study`` (:data:`STUDY_TYPES`), writing under ``out_dir``."""
    kind = next(kind for kind in STUDY_TYPES if kind.applies_to(study))
    return kind(study, Path(out_dir))


def run_study(study: Study, out_dir: str | Path, options: RunOptions | None = None,
              progress: Progress | None = None, kind: StudyType | None = None):
    """Run ``study`` into ``out_dir`` (module doc); the outcome of its type.

    StudyError (nothing written) for a study that cannot run: a field, the memory, an unreachable
    scheduler (asked once, before anything is written); the core's DivergenceError where the type
    stops on it."""
    options = options or RunOptions()
    progress = progress or Progress()
    kind = kind or study_type(study, out_dir)
    wall_start = time.perf_counter()
    kind.check(options)
    for warning in kind.warnings():
        progress.message(warning)
    if options.scheduler and study.strength_reduction is not None:
        from workflows.fos.cluster import check_scheduler  # dask: once the study is known to be valid

        check_scheduler(options.scheduler)

    def on_case(case_id, outcome):
        kind.case_concluded(case_id, outcome, progress)

    with folder_lock(out_dir, study.name, progress.message, force=options.force, digest=study_digest(study)):
        cases = kind.cases()  # it writes, and may remove what an earlier invocation made: with the lock held
        with _round_session(kind, study, options) as session:
            outcomes, timings = run_cases(cases, kind.placement, options, progress, wall_start, session, on_case,
                                          kind.feed())
            while cases := kind.next_cases(outcomes, progress):
                more, more_timings = run_cases(cases, kind.placement, options, progress, wall_start, session,
                                               on_case, kind.feed())
                outcomes.update(more)
                timings.add(more_timings)
            return kind.conclude(outcomes, timings, wall_start)


def _round_session(kind: StudyType, study: Study, options: RunOptions):
    """One dask session for every round of a strength-reduction study made in rounds (a cluster
    start saved per round); else none (each round's cases start and close their own)."""
    if not (kind.placement.rounds and study.strength_reduction is not None):
        return nullcontext(None)
    from workflows.fos.cluster import dask_session  # dask: once the study is known to be valid

    return dask_session(options.workers, options.scheduler, warm_up_worker=kind.placement.gravity_in_process)
