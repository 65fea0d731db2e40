"""The kinds of study, the rule by which ``[sweep]`` composes with them, and the one way to run any.

A study type (``workflows.cases.StudyType``) makes its cases, says how they run (its
``Placement``), and brings their outcomes together.  The type of a study without ``[sweep]`` is
the first of :data:`STUDY_TYPES` that takes it:

- ``fos_time.study_type.TransientStudy``: a study of the FOS against time (``[transient]`` with
  ``fos_times_h`` or ``fos_interval_h``), a case per time, one after another, ``fos_time.nc``;

- a study with ``[probabilistic]``: the type that plans the rounds of its method
  (:data:`METHOD_STUDY_TYPES`, by ``probabilistic.kinds.METHODS``):
  - ``probabilistic.study_type.ProbabilisticStudy``: ``monte_carlo`` or ``latin_hypercube``, a case per
    realisation of its random variables (run as a sweep's), and ``probabilistic.nc`` with pf;
  - ``probabilistic.form_study.FormStudy``: ``method = "form"``, a case per point it places,
    FORM's iterations in rounds, and ``probabilistic.nc`` with beta and the design point;
  - ``probabilistic.point_estimate_study.PointEstimateStudy``: ``method = "point_estimate"``, its
    2^n points in one round, and ``probabilistic.nc`` with the FOS's moments;
  - ``probabilistic.subset_study.SubsetStudy``: ``method = "subset_simulation"``, level after level of
    Markov chains on the FOS (rounds), and ``probabilistic.nc`` with pf and its coefficient of variation;
- ``refinement.study_type.RefinementStudy``: a study with ``[refinement]``, a case per particle
  spacing, each after the one before (rounds: ``StudyType.next_cases``), and ``refinement.nc``;
- ``single.SingleStudy``: any other, one case in the output folder.

With ``[sweep]``, each case of the sweep is a study of that type (the rule, :func:`study_type`):
a sweep of single studies is ``sweep.study_type.SweepStudy`` (a case per combination of the axes'
values, computed together, and ``study.nc``); a sweep of any type that makes cases of its own is
``sweep.nested.NestedSweep`` of it: each case a study of that type in its own folder, every case's
cases computed together, and ``study.nc`` as :data:`SWEPT` says a sweep of that type writes it
(``refinement.sweep.RefinedSweep``, ``probabilistic.sweep.ProbabilisticSweep``).

:func:`run_study` asks the study for its type once, checks it, makes its cases, computes them
with the one case runner (``workflows.cases.run_cases``), round after round while the type makes
more, and concludes.
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from pathlib import Path

from workflows.cases import RunOptions, StudyType, run_cases
from workflows.fos_time.study_type import TransientStudy
from workflows.output.folder_lock import folder_lock, study_digest
from workflows.probabilistic.form_study import FormStudy
from workflows.probabilistic.kinds import METHODS, Method
from workflows.probabilistic.point_estimate_study import PointEstimateStudy
from workflows.probabilistic.study_type import ProbabilisticStudy
from workflows.probabilistic.subset_study import SubsetStudy
from workflows.probabilistic.sweep import ProbabilisticSweep
from workflows.progress import Progress
from workflows.refinement.study_type import RefinementStudy
from workflows.refinement.sweep import RefinedSweep
from workflows.single import SingleStudy
from workflows.study import Study, StudyError
from workflows.sweep.nested import NestedSweep, SweepSummary
from workflows.sweep.study_type import SweepStudy

STUDY_TYPES: tuple[type[StudyType], ...] = (ProbabilisticStudy, RefinementStudy, TransientStudy, SingleStudy)
"""Every type of a study without ``[sweep]``, asked in this order whether a study is of it (the last
takes any study); a probabilistic study's is then the one of :data:`METHOD_STUDY_TYPES`."""
METHOD_STUDY_TYPES: dict[Method, type[ProbabilisticStudy]] = {
    METHODS["monte_carlo"]: ProbabilisticStudy, METHODS["latin_hypercube"]: ProbabilisticStudy,
    METHODS["form"]: FormStudy, METHODS["point_estimate"]: PointEstimateStudy,
    METHODS["subset_simulation"]: SubsetStudy,
}
"""The study type that plans the rounds of each probabilistic method (``[probabilistic] method``)."""
SWEPT: dict[type[StudyType], SweepSummary] = {ProbabilisticStudy: ProbabilisticSweep(), RefinementStudy: RefinedSweep()}
"""What a sweep of each type that makes cases of its own writes (``sweep.nested.SweepSummary``)."""


def study_type(study: Study, out_dir: str | Path) -> StudyType:
    """The type of ``study`` (module doc), writing under ``out_dir``; StudyError for a sweep of a type
    without its entry in :data:`SWEPT`."""
    kind = next(kind for kind in STUDY_TYPES if kind.applies_to(study))
    if study.probabilistic is not None:
        kind = METHOD_STUDY_TYPES[study.probabilistic.method_kind]
    if study.sweep is None:
        return kind(study, Path(out_dir))
    if kind is SingleStudy:  # a sweep's cases are single studies: computed together as its own
        return SweepStudy(study, Path(out_dir))
    if kind not in SWEPT:  # (a type's table refuses [sweep] until a sweep of it is written)
        raise StudyError("sweep", f"does not apply to {kind.label} yet")
    return NestedSweep(study, Path(out_dir), kind, SWEPT[kind])


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
