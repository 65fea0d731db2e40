"""The FOS against time: a study with ``[transient]`` and ``fos_times_h`` or ``fos_interval_h``.

1. The flow is solved once on the particles' first mesh (``workflows.transient.flow``) and written to
   ``OUT/transient.nc`` (heads, saturations, flow and the water balance at each saved time).
2. A case per time, in order, each in ``OUT/times/t=<t>h/`` as a single study (its ``case.toml``: the
   study with ``water_at_h = t``), carrying the water of that time (passed on, not solved again): its
   own gravity state, then its strength-reduction search.  From the second time on the search starts in
   a window about the FOS predicted from the times before (``fos.prediction.search_window``): the last
   FOS continued along the last change, its expected error half that change (``ONE_CASE_SIGMA`` of F with
   one time before, at least ``MIN_SIGMA``).  A window that misses grows: the prediction costs runs,
   never the answer.
3. With ``stop_below_fos`` the study stops after the first time whose FOS is below it (the state of that
   case, its failed runs, is what a runout would start from).
4. ``OUT/fos_time.nc`` (the FOS, its bracket, the runs and window of each time, with the rain and the
   reservoir's level) and ``fos_time.png`` (the FOS against time above the rain or the level); a
   ``fos_time.png`` of an earlier invocation not drawn again (``figures = false``) is removed.
5. With ``runout_duration_s``, the slope that failed is followed after failure (``OUT/runout/``): the
   study of that time with a runout stage (its own strength, strength_factor 1) in place of the strength
   reduction, from its gravity state, the water of that time carried as through the searches.
"""

from __future__ import annotations

import dataclasses
import math
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from workflows.cases import Case, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.fos_time.figures import FIGURE_NAME, draw_fos_time
from workflows.fos_time.results import FILE_NAME, below, bracket, fos_time_dataset, time_fos_reaches, upper_values
from workflows.memory_guard import check_memory
from workflows.output.figures import remove_stale_figures
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.study import Study
from workflows.study.reading import parse_study
from workflows.study.toml_text import to_toml
from workflows.transient.results import balance_line, write_transient

TIMES_FOLDER = "times"
CASE_TEXT_NAME = "case.toml"
RUNOUT_FOLDER = "runout"
RUNOUT_RECORD_INTERVAL_S = 0.01


def case_id(time_h: float) -> str:
    """The folder of the case at ``time_h``."""
    return f"t={time_h:.6g}h"


@dataclass
class TransientOutcome:
    """What a study of the FOS against time did and found."""

    out_dir: Path
    times_h: list[float]  # the times searched (up to the stop)
    outcomes: dict  # case id -> fos.summary.FosOutcome
    windows: dict  # case id -> (low, high, step) or None
    transient_path: Path
    fos_time_path: Path
    balance_fraction: float  # the flow's closure: |in - out - stored| / max(in, out, stored), worst saved time
    flow_wall_s: float
    stopped_at_h: float | None  # the time the study stopped at (stop_below_fos), None: it ran every time
    time_fos_one_h: float  # when the FOS reaches 1, interpolated between the times either side (NaN: never)
    runout: Any = None  # the runout of the failing state (``stages.running.StudyRun``), if one was asked for
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)


class TransientStudy(StudyType):
    """A study of the FOS against time (module doc)."""

    label = "a study of the FOS against time"
    stale_figures: list[str] = []  # fos_time.png of an earlier invocation not drawn again (figures = false), removed

    @property
    def placement(self) -> Placement:
        """Each time's gravity in this process, its runs on the cluster, one time after another (rounds);
        figures as ``[output] figures`` says."""
        return Placement(gravity_in_process=True, figures=self.study.output.figures, quiet_cases=True,
                         keep_going=False, rounds=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.transient is not None and study.transient.against_time

    def check(self, options: RunOptions) -> None:
        """The resolution of the strength reduction; the memory of this process and the local workers."""
        self.study.strength_reduction.check_resolution(self.study)
        check_memory(self.study, processes=self.processes(options), limit_bytes=options.max_memory_bytes)

    def case_study(self, time_h: float) -> Study:
        """The study of the case at ``time_h``: this one with ``water_at_h = time_h`` (and none of the
        FOS against time)."""
        raw = tomllib.loads(self.study.source_text)
        transient = raw["transient"]
        for name in ("fos_times_h", "fos_interval_h", "stop_below_fos", "runout_duration_s"):
            transient.pop(name, None)
        transient["water_at_h"] = float(time_h)
        return parse_study(to_toml(raw, header=f"the case at {time_h:g} h of study {self.study.name}"))

    def runout_study(self, time_h: float) -> Study:
        """The study that follows the slope after failure at ``time_h``: the case of that time with its
        strength-reduction stage replaced by a runout stage at the slope's own strength (module doc, step 3)."""
        raw = tomllib.loads(self.case_study(time_h).source_text)
        stage = raw["stages"][-1]
        raw["stages"][-1] = {"name": "runout", "kind": "runout", "strength_factor": 1.0,
                             "max_duration_s": self.study.transient.runout_duration_s,
                             "record_interval_s": RUNOUT_RECORD_INTERVAL_S,
                             **({"boundary": stage["boundary"]} if "boundary" in stage else {})}
        return parse_study(to_toml(raw, header=f"the runout after failure at {time_h:g} h of study {self.study.name}"))

    def _case(self, index: int) -> Case:
        time_h = self.times_h[index]
        folder = self.out_dir / TIMES_FOLDER / case_id(time_h)
        study = self.case_study(time_h)
        make_output_folder(folder)
        write_text_if_changed(folder / CASE_TEXT_NAME, study.source_text)
        case = Case(study, folder, case_id(time_h), (index,), {"time_h": time_h}, flow=self.flow.water_at(time_h))
        window = self._window(index)
        self.windows[case.case_id] = window
        return case if window is None else dataclasses.replace(case, window=window)

    def _window(self, index: int) -> tuple[float, float, float] | None:
        """The window of the case at ``times_h[index]`` (module doc, step 2); None for the first."""
        from workflows.fos.prediction import MIN_SIGMA, ONE_CASE_SIGMA, Prediction, search_window  # (scipy: on use)

        known = [(t, self.fos[case_id(t)]) for t in self.times_h[:index] if math.isfinite(self.fos[case_id(t)])][-2:]
        if not known:
            return None
        t_last, f_last = known[-1]
        if len(known) == 1:
            prediction = Prediction(f_last, ONE_CASE_SIGMA * f_last, "the FOS of the time before")
        else:
            t_before, f_before = known[-2]
            change = (f_last - f_before) * (self.times_h[index] - t_last) / (t_last - t_before)
            prediction = Prediction(max(f_last + change, 0.05), max(0.5 * abs(change), MIN_SIGMA * f_last),
                                    "the FOS of the times before, continued")
        return search_window(prediction, self.study.strength_reduction.fos_tolerance)

    def cases(self) -> list[Case]:
        """The flow solved and written (module doc, step 1); the first time's case."""
        from workflows.transient.flow import transient_flow  # the core's mesh (numba): once the study is valid

        self.times_h = list(self.study.transient.fos_times())
        self.fos: dict[str, float] = {}
        self.outcomes: dict = {}
        self.windows: dict = {}
        self.flow = transient_flow(self.study)
        make_output_folder(self.out_dir)
        self.transient_path = write_transient(self.study, self.flow, self.out_dir)
        return [self._case(0)]

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        """A time's case (``cases.Concluded``: its ``fos.summary.FosOutcome``); a time whose gravity
        diverged ends the study with the core's error (``keep_going`` is off: no later time can follow)."""
        if outcome.diverged:
            raise outcome.error
        self.fos[case_id] = outcome.fos
        self.outcomes[case_id] = outcome.result
        progress.message(f"{case_id}: {outcome.result.verdict} ({len(outcome.runs)} runs)")

    def next_cases(self, outcomes: dict, progress) -> list[Case]:
        """The next time's case, unless the last FOS fell below ``stop_below_fos`` or none is left."""

        done = len(outcomes)
        stop = self.study.transient.stop_below_fos
        last = self.outcomes[case_id(self.times_h[done - 1])]
        if done >= len(self.times_h) or (stop is not None and below(last, stop)):
            return []
        return [self._case(done)]

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> TransientOutcome:
        """``fos_time.nc`` and ``fos_time.png`` (module doc, step 4)."""

        times = self.times_h[:len(outcomes)]
        ordered = {case_id(t): self.outcomes[case_id(t)] for t in times}  # their FosOutcome
        stop = self.study.transient.stop_below_fos
        stopped = times[-1] if len(times) < len(self.times_h) else None
        dataset = fos_time_dataset(self.study, self.flow, times, ordered, self.windows, stop)
        path = write_dataset(dataset, self.out_dir / FILE_NAME)
        figures = [draw_fos_time(self.study, dataset, self.flow, self.out_dir)] if self.study.output.figures else []
        self.stale_figures = remove_stale_figures(self.out_dir, (FIGURE_NAME,), keep={p.name for p in figures})
        runout = None
        if self.study.transient.runout_duration_s is not None and below(ordered[case_id(times[-1])],
                                                                         self.study.transient.stop_below_fos):
            runout = self._run_out(times[-1])
        timings_s = {"flow": self.flow.wall_time_s, "cases_elapsed": timings.cases_elapsed,
                     "gravity": sum(o.timings_s.get("gravity", 0.0) for o in ordered.values()),
                     "srf_runs_worker": timings.srf_runs_worker, "total": time.perf_counter() - wall_start}
        return TransientOutcome(self.out_dir, times, ordered, dict(self.windows), self.transient_path, path,
                                float(self.flow.solution.balance_fraction().max()), self.flow.wall_time_s, stopped,
                                time_fos_reaches(times, upper_values(ordered.values()), 1.0), runout, timings_s,
                                figures)

    def _run_out(self, time_h: float):
        """The runout of the slope that failed at ``time_h`` (:meth:`runout_study`), its stages in this process,
        carrying the water of that time (passed on, not solved again)."""
        from workflows.stages.running import run_stages  # the core (numba): once the study is valid

        folder = self.out_dir / RUNOUT_FOLDER
        study = self.runout_study(time_h)
        make_output_folder(folder)
        write_text_if_changed(folder / CASE_TEXT_NAME, study.source_text)
        return run_stages(study, folder, flow=self.flow.water_at(time_h))

    def report(self, outcome: TransientOutcome, quiet: bool, study_file) -> Report:

        table = [f"{'t (h)':>8}  {'FOS':>6}  {'bracket':>17}  {'runs':>4}  window"]
        for t, (cid, fos_outcome) in zip(outcome.times_h, outcome.outcomes.items()):
            window = outcome.windows.get(cid)
            shown = "-" if window is None else f"[{window[0]:.3g}, {window[1]:.3g}] step {window[2]:.3g}"
            fos, low, high = bracket(fos_outcome)
            value = f"{fos:6.3f}" if math.isfinite(fos) else (f"<{high:5.3g}" if math.isfinite(high) else f">{low:5.3g}")
            table.append(f"{t:8.4g}  {value:>6}  [{low:.4g}, {high:.4g}]  {len(fos_outcome.runs):4d}  {shown}")
        one = outcome.time_fos_one_h
        found = [f for f in (bracket(o)[0] for o in outcome.outcomes.values()) if math.isfinite(f)]
        verdict = (f"FOS reaches 1 at about {one:.3g} h (interpolated between the times either side)"
                   if math.isfinite(one) else f"FOS stays above 1 to {outcome.times_h[-1]:g} h"
                   + (f" (lowest {min(found):.3g})" if found else ""))
        if quiet:
            return Report([verdict])
        runs = sum(len(o.runs) for o in outcome.outcomes.values())
        timings = outcome.timings_s
        header = (f"{self.study.name}: FOS at {len(outcome.times_h)} times, {runs} SRF runs "
                  f"({runs / max(len(outcome.times_h), 1):.1f} per FOS), wall time {timings['total']:.1f} s "
                  f"(the flow {timings['flow']:.1f} s, {timings['flow'] / max(timings['total'], 1e-9):.1%})")
        stopped = ([f"stopped after {outcome.stopped_at_h:g} h: FOS below stop_below_fos = "
                    f"{self.study.transient.stop_below_fos:g}"] if outcome.stopped_at_h is not None else [])
        if outcome.runout is not None:
            stopped.append(f"the runout after failure at {outcome.times_h[-1]:g} h: "
                           + ", ".join(str(path) for path in outcome.runout.paths)
                           + "".join(f"; {warning}" for warning in outcome.runout.warnings))
        wrote = (f"wrote {outcome.transient_path}, {outcome.fos_time_path.name}, {TIMES_FOLDER}/"
                 + "".join(f", {path.name}" for path in outcome.figures))
        removed = ([f"removed what an earlier invocation made: figures not drawn again ({', '.join(self.stale_figures)})"]
                   if self.stale_figures else [])  # (the words of a sweep's line, sweep.stale)
        return Report([header, verdict, *table, *stopped, balance_line(self.flow), wrote, *removed])
