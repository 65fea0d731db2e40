"""A single study: one case, the study itself, in the output folder.

A strength-reduction study computes its gravity state in this process on all cores while the
cluster starts, its SRF runs on the cluster, and draws its figures; any other study runs its
stages in this process.  A case that diverges stops the study (exit code 1).
"""

from __future__ import annotations

from workflows.cases import Case, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.fos.discretisation import note
from workflows.memory_guard import check_memory
from workflows.study import Study


class SingleStudy(StudyType):
    """A study without ``[sweep]`` (module doc)."""

    label = "a single study"

    @property
    def placement(self) -> Placement:
        """Gravity in this process; figures as ``[output] figures`` says (a single FOS study drew them
        whatever it said)."""
        return Placement(gravity_in_process=True, figures=self.study.output.figures, quiet_cases=False,
                         keep_going=False)

    @staticmethod
    def applies_to(study: Study) -> bool:
        """Any study (the last type asked: ``workflows.study_types``)."""
        return True

    def check(self, options: RunOptions) -> None:
        """A strength-reduction study's resolution; the memory of this process (and of the local workers
        of a strength-reduction study, ``memory_guard``)."""
        stage = self.study.strength_reduction
        if stage is not None:
            stage.check_resolution(self.study)
        check_memory(self.study, processes=self.processes(options), limit_bytes=options.max_memory_bytes)

    def cases(self) -> list[Case]:
        return [Case(self.study, self.out_dir)]

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float):
        """The one case's result: a ``fos.summary.FosOutcome`` or a ``stages.running.StudyRun`` (a case
        that diverges stops a single study: it is never ``Diverged``)."""
        return outcomes[""].result

    def report(self, outcome, quiet: bool, study_file) -> Report:
        if self.study.strength_reduction is not None:
            return self._fos_report(outcome, quiet)
        return self._stages_report(outcome, quiet, study_file)

    def _fos_report(self, outcome, quiet: bool) -> Report:
        from workflows.fos.report import report_lines  # the core (numba): once the study is known to be valid

        if quiet:
            return Report([outcome.verdict])
        header = (f"{self.study.name}: {outcome.n_particles} particles, {len(outcome.runs)} SRF runs, "
                  f"wall time {outcome.timings_s['total']:.1f} s")
        wrote = f"wrote {outcome.summary_path}" + "".join(f", {path.name}" for path in outcome.figures)
        lines = report_lines(outcome)
        lines.insert(lines.index(outcome.verdict) + 1, note(self.study))
        return Report([header, *lines, wrote])

    def _stages_report(self, outcome, quiet: bool, study_file) -> Report:
        warnings = [f"warning: stage {name!r} reached max_duration_s before converging (converged = 0)"
                    for name in outcome.unconverged_stages] + outcome.warnings
        paths = ", ".join(str(path) for path in outcome.paths)
        if outcome.up_to_date:
            return Report([f"{paths}: up to date with {study_file}, not run again (--force runs it)"], warnings)
        lines = [f"{self.study.name}: {outcome.n_particles} particles, {outcome.n_steps} steps of "
                 f"{outcome.dt_s:.3g} s, wall time {outcome.wall_time_s:.1f} s"]
        if not quiet:
            lines.append(f"wrote {paths}")
        return Report(lines, warnings)

