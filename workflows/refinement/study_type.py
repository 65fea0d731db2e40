"""A refinement study: the FOS at each spacing of ``[refinement]``, one level after the other, and
``OUT/refinement.nc`` with the extrapolation to h -> 0 (``workflows.refinement.convergence``).

1. Level k is the study itself at spacing h_k with the search tolerance of ``[refinement]``, in
   ``OUT/levels/<k>_h=<h_k>/`` (its ``case.toml``, gravity, runs and ``summary.nc`` kept there
   exactly as a single study keeps them, and reused by the next invocation while their keys hold).
2. The first level searches the stage's own SRF range.  Each later level searches a window around
   the FOS of the level before, from ``fos - 3 d`` to ``fos + 2 d`` in steps of ``d`` (:func:`window`;
   the FOS falls with h on most slopes, docs/verification.md), so that it makes only the few runs
   near its FOS.  If its FOS lies outside the window (every run stable; every run failed, or too
   few stable runs below the first failure for a knee), the window grows by its width in that
   direction and the level goes on, its runs so far reused (at most ``MAX_WINDOW_MOVES`` times).
   It grows rather than moves: a FOS just at the window's edge (one stable run below the first
   failure) must not send the window back and forth past it.
3. ``OUT/refinement.nc`` and ``convergence.png`` are written last; a study that stopped early
   leaves none (the one of an earlier invocation is removed at the start).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from workflows.cases import Case, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.memory_guard import check_memory
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.refinement.convergence import Extrapolation, extrapolate
from workflows.study import Study, StudyError
from workflows.study.reading import _build_study, _loads, resolve_sweep_path
from workflows.study.toml_text import to_toml

LEVELS_FOLDER = "levels"
CASE_TEXT_NAME = "case.toml"
RESULT_NAME = "refinement.nc"
MAX_WINDOW_MOVES = 3
"""A level's window grows at most this many times before the level is given up."""
WINDOW_BELOW, WINDOW_ABOVE = 3, 2
"""A later level's window reaches this many steps d below and above the FOS of the level before."""
FIRST_STEP = 0.01
"""d of the second level, a fraction of the first level's FOS (later: the change between levels)."""


@dataclass
class LevelResult:
    """One level's FOS and what it cost."""

    spacing_m: float
    fos: float
    fos_low: float
    fos_high: float
    n_particles: int
    n_runs: int  # runs the level's FOS rests on (made now or reused)
    n_runs_made: int  # of them, made by this invocation
    wall_time_s: float  # worker time of its gravity and runs made now
    verdict: str
    criteria_agree: bool


@dataclass
class RefinementOutcome:
    """What a refinement study did and found."""

    out_dir: Path
    result_path: Path
    levels: list[LevelResult]
    extrapolation: Extrapolation | None  # None: fewer than three levels have an FOS
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)
    message: str = ""  # why there is no extrapolation

    @property
    def verdict(self) -> str:
        """The report's first line: the FOS as h -> 0 with its band, or why there is none (an adaptive
        study: the FOS of its refined level)."""
        x = self.extrapolation
        if x is None and self.message.startswith("adaptive refinement:"):
            level = self.levels[-1]
            return (f"FOS = {level.fos:.4f}, bracket [{level.fos_low:.4f}, {level.fos_high:.4f}] with a band of "
                    f"{level.spacing_m:g} m particles along the shear band ({level.n_particles} particles; coarse "
                    f"level {self.levels[0].fos:.4f})")
        if x is None:
            return f"no FOS at h -> 0: {self.message}"
        what = {"extrapolated": f"FOS = {x.fos:.4f} at h -> 0 (Richardson, observed order {x.observed_order:.2g})",
                "converged": f"FOS = {x.fos:.4f}, converged in h"}.get(x.status, f"FOS = {x.fos:.4f} at the finest h")
        return (f"{what}; discretisation band [{x.band_low:.4f}, {x.band_high:.4f}] (+-{100 * x.gci:.2g}%, "
                f"{x.status.replace('_', ' ')})")


def window(fos: float, step: float) -> tuple[float, float, float]:
    """(srf_min, srf_max, srf_step) of a later level around the FOS of the level before."""
    step = max(round(step, 4), 0.001)
    low = max(round(fos - WINDOW_BELOW * step, 4), 0.01)
    return low, round(low + (WINDOW_BELOW + WINDOW_ABOVE) * step, 4), step


class RefinementStudy(StudyType):
    """A study with ``[refinement]`` (module doc)."""

    placement = Placement(gravity_in_process=True, figures=False, quiet_cases=True, keep_going=False, rounds=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.refinement is not None

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.spacings = study.refinement.spacings(study.geometry.spacing_m)
        self.level_studies = [self._level_study(k, h) for k, h in enumerate(self.spacings)]
        if self.adaptive:  # the zone comes from the first level's failed run: until then, the coarse study
            self.level_studies[1] = self.level_studies[0]
        self.moves = [0] * len(self.spacings)
        self.current = 0  # the level being computed
        self.found: dict[int, float] = {}  # FOS of each level done

    @property
    def adaptive(self) -> bool:
        return self.study.refinement.adaptive_spacing_m is not None

    def _level_study(self, k: int, spacing_m: float, search: tuple[float, float, float] | None = None,
                     zone: list | None = None) -> Study:
        """Level k's own study: the study at ``spacing_m`` with the levels' tolerance and, for a later
        level, the SRF window ``search`` = (srf_min, srf_max, srf_step); an adaptive level keeps the
        coarse spacing and adds the refined ``zone`` polygon at ``spacing_m``.  The coarse level of
        an adaptive study keeps the stage's tolerance: it gives the refined level its shear band and
        the middle of its window, not an answer."""
        raw = _loads(self.study.source_text)
        raw.pop("refinement", None)
        if zone is not None:
            raw.setdefault("geometry", {}).setdefault("refined", []).append(
                {"name": "adaptive_band", "region_m": zone, "spacing_m": spacing_m})
            spacing_m = self.study.geometry.spacing_m
        stage = self.study.strength_reduction.name
        values = {"geometry.spacing_m": spacing_m}
        if not (self.adaptive and k == 0):  # an adaptive study's coarse level: the stage's own tolerance
            values[f"stages.{stage}.fos_tolerance"] = self.study.refinement.fos_tolerance
        if search is not None:
            values.update({f"stages.{stage}.{name}": value for name, value in zip(("srf_min", "srf_max", "srf_step"),
                                                                                  search)})
        case_raw = copy.deepcopy(raw)
        for path, value in values.items():
            node, key, _ = resolve_sweep_path(case_raw, path)
            node[key] = value
        text = to_toml(case_raw, header=f"level {k} (h = {spacing_m:g} m) of the refinement study {self.study.name}")
        try:
            return dataclasses.replace(_build_study(case_raw), source_text=text)
        except StudyError as error:
            raise StudyError("refinement", f"level {k} (h = {spacing_m:g} m): {error}") from None

    def folder(self, k: int) -> Path:
        return self.out_dir / LEVELS_FOLDER / f"{k}_h={self.spacings[k]:g}"

    def check(self, options: RunOptions) -> None:
        """Each level's resolution; the memory of the finest level (StudyError; an adaptive study's
        finest level is not known before the first has run: its coarse level is checked)."""
        for k, study in enumerate(self.level_studies):
            try:
                study.strength_reduction.check_resolution(study)
            except StudyError as error:
                raise StudyError("refinement", f"level {k} (h = {self.spacings[k]:g} m): {error}") from None
        check_memory(self.level_studies[-1], processes=1 + (0 if options.scheduler else options.workers),
                     limit_bytes=options.max_memory_bytes)

    def warnings(self) -> list[str]:
        """Thin layers at the finest level (``workflows.layers``)."""
        from workflows.layers import thin_layer_warnings

        return thin_layer_warnings(self.level_studies[-1])

    def _case(self, k: int) -> Case:
        folder = self.folder(k)
        make_output_folder(folder)
        write_text_if_changed(folder / CASE_TEXT_NAME, self.level_studies[k].source_text)
        return Case(self.level_studies[k], folder, self._case_id(k))

    def cases(self) -> list[Case]:
        make_output_folder(self.out_dir)
        (self.out_dir / RESULT_NAME).unlink(missing_ok=True)  # a stopped study must not show an old one
        return [self._case(0)]

    def next_cases(self, outcomes: dict, progress) -> list[Case]:
        """The next level, or the current one in a grown window, or none when done (module doc, step 2)."""
        k = self.current
        outcome = outcomes[self._case_id(k)]
        stage = self.level_studies[k].strength_reduction
        if math.isfinite(outcome.fos):
            progress.message(f"level {k}: h = {self.spacings[k]:g} m, {outcome.n_particles} particles: FOS "
                             f"{outcome.fos:.4f} [{outcome.fos_low:.4f}, {outcome.fos_high:.4f}], {len(outcome.runs)} runs")
            self.found[k] = outcome.fos
            if k + 1 == len(self.spacings):
                return []
            zone = None
            if self.adaptive:
                from workflows.fos.run_store import run_file_name
                from workflows.refinement.adaptive import band_zone

                margin = self.study.refinement.band_margin_m or self.study.geometry.spacing_m
                zone = band_zone(outcome.out_dir / run_file_name(outcome.status_high), self.study.geometry.spacing_m,
                                 margin)
                if zone is None:
                    progress.message(f"warning: level {k}'s first failed run has no shear band to refine")
                    return []
            self.current = k + 1
            self.level_studies[k + 1] = self._level_study(k + 1, self.spacings[k + 1],
                                                          window(outcome.fos, self._step()), zone)
            return [self._case(k + 1)]
        stable_below = [r for r in outcome.runs if r.status == "stable" and r.srf < outcome.status_high]
        every_failed = math.isfinite(outcome.status_high) and len(stable_below) < 2  # no knee without 2 below
        no_failure = math.isnan(outcome.status_high)
        if k == 0 or self.moves[k] >= MAX_WINDOW_MOVES or not (every_failed or no_failure):
            progress.message(f"warning: level {k} (h = {self.spacings[k]:g} m) has no FOS: {outcome.verdict}")
            return []
        self.moves[k] += 1
        width = stage.srf_max - stage.srf_min
        low, high = (stage.srf_min - width, stage.srf_max) if every_failed else (stage.srf_min, stage.srf_max + width)
        search = (max(round(low, 4), 0.01), round(high, 4), stage.srf_step)
        progress.message(f"level {k}: the FOS lies {'below' if every_failed else 'above'} SRF "
                         f"{stage.srf_min if every_failed else stage.srf_max:g}: searching [{search[0]:g}, {search[1]:g}]")
        self.level_studies[k] = self._level_study(k, self.spacings[k], search)
        return [self._case(k)]

    def _case_id(self, k: int) -> str:
        return f"level {k} (h = {self.spacings[k]:g} m)"

    def _step(self) -> float:
        """d: the larger of 2.5 search tolerances and the change of the FOS between the last two levels
        (``FIRST_STEP`` of the FOS when only one level is done)."""
        tolerance = self.study.refinement.fos_tolerance
        found = [self.found[k] for k in sorted(self.found)]
        change = abs(found[-1] - found[-2]) if len(found) >= 2 else FIRST_STEP * found[-1]
        return max(2.5 * tolerance, change)

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> RefinementOutcome:
        from workflows.refinement.results import refinement_dataset  # xarray: once the levels have run

        levels = []
        for k in range(len(self.spacings)):
            outcome = outcomes.get(self._case_id(k))
            if outcome is None:
                continue
            made = [run for run in outcome.runs if run.started_s == run.started_s]  # NaN: reused
            levels.append(LevelResult(
                self.spacings[k], outcome.fos, outcome.fos_low, outcome.fos_high, outcome.n_particles,
                len(outcome.runs), len(made), outcome.timings_s["gravity"] + sum(run.wall_time_s for run in made),
                outcome.verdict, outcome.criteria_agree))
        found = [level for level in levels if math.isfinite(level.fos)]
        extrapolation, message = None, ""
        if self.adaptive:
            message = ("adaptive refinement: no extrapolation; the FOS of the refined band is the finest level's"
                       if len(found) == 2 else f"{len(found)} of 2 levels have an FOS")
        elif len(found) >= 3:
            resolution = max(0.5 * (level.fos_high - level.fos_low) for level in found)
            extrapolation = extrapolate([level.spacing_m for level in found], [level.fos for level in found],
                                        resolution, self.study.refinement.safety_factor)
        else:
            message = f"{len(found)} of {len(self.spacings)} levels have an FOS, at least 3 are needed"
        result = RefinementOutcome(self.out_dir, self.out_dir / RESULT_NAME, levels, extrapolation, message=message)
        result.timings_s = {"levels_elapsed": timings.cases_elapsed, "total": time.perf_counter() - wall_start}
        dataset = refinement_dataset(self.study, result)
        write_dataset(dataset, result.result_path)
        if self.study.output.figures:
            from workflows.refinement.figures import draw_convergence  # matplotlib only when drawing

            result.figures = draw_convergence(self.out_dir, dataset)
        return result

    def report(self, outcome: RefinementOutcome, quiet: bool, study_file) -> Report:
        lines = [outcome.verdict]
        if quiet:
            return Report(lines)
        lines.append(f"{'level':>5}  {'h (m)':>8}  {'particles':>9}  {'FOS':>7}  {'bracket':>17}  runs")
        for k, level in enumerate(outcome.levels):
            lines.append(f"{k:5d}  {level.spacing_m:8.4g}  {level.n_particles:9d}  {level.fos:7.4f}  "
                         f"[{level.fos_low:.4f}, {level.fos_high:.4f}]  {level.n_runs:4d}")
        if outcome.extrapolation is not None:
            lines.append(outcome.extrapolation.reason)
        lines.append(f"wall time {outcome.timings_s['total']:.1f} s; wrote {outcome.result_path}"
                     + "".join(f", {path.name}" for path in outcome.figures) + f", {self.out_dir / LEVELS_FOLDER}/")
        return Report(lines)
