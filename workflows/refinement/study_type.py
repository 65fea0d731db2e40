"""A refinement study: the FOS at a sequence of spacings, its value as h -> 0 and its uncertainty
(``workflows.refinement.convergence``), in ``OUT/refinement.nc``.

1. Level k is the study itself with the search tolerance of ``[refinement]``, in
   ``OUT/levels/<k>_h=<h_k>/`` (its ``case.toml``, gravity, runs and ``summary.nc`` kept there
   exactly as a single study keeps them, and reused by the next invocation while their keys hold).
   Its interior particles are jittered by ``[refinement] jitter`` with a seed of its own, so that
   the levels are independent samples of the FOS at their spacings.
   - ``uniform``: the whole cloud at h_k;
   - ``adaptive``: the first level at ``geometry.spacing_m``; level k adds zones of spacing
     h_k = h_0 / ratio^k around the shear band of level k - 1's first failed run
     (``workflows.refinement.adaptive``), reaching ``band_reach`` h_(k-1) beyond it, and keeps the
     zones of the levels before (nested: the mechanism may move within them as h falls).
2. The first level searches the stage's SRF range.  Each later level searches a window about the
   FOS its predecessors predict (:func:`predicted_fos`): from ``F - 2 d`` to ``F + 2 d`` in steps of
   ``d``.  If its FOS lies outside (every run stable; every run failed, or too few stable runs below
   the first failure for a knee), the window grows by its width that way and the level goes on, its
   runs so far reused (at most ``MAX_WINDOW_MOVES`` times).
3. With a jitter, the second level is repeated with another seed in the same round: the measured
   scatter of the FOS, |F_1 - F_1'| / sqrt 2.
4. An adaptive study stops once it has ``MIN_LEVELS`` levels and a trusted band no wider than
   ``target_uncertainty`` of the FOS, or at ``max_levels``, or when the next level would hold more
   than ``max_particles`` particles; a uniform study after its last spacing.
5. ``OUT/refinement.nc`` and ``convergence.png`` are written last; a study that stopped early
   leaves none (the one of an earlier invocation is removed at the start).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from workflows.cases import Case, CaseTimings, Placement, Report, RunOptions, StudyType
from workflows.layers import thin_layer_warnings
from workflows.memory_guard import BYTES_PER_PARTICLE, GIB, available_memory_bytes, check_memory, estimated_particles
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.refinement.adaptive import band_indicator, band_particles, zone_outlines
from workflows.refinement.convergence import MIN_LEVELS, DiscretisationBand, discretisation_band
from workflows.refinement.figures import draw_convergence
from workflows.refinement.results import refinement_dataset
from workflows.study import Study, StudyError
from workflows.study.reading import _build_study, _loads, resolve_sweep_path
from workflows.study.toml_text import to_toml

if TYPE_CHECKING:
    from workflows.fos.summary import FosOutcome

LEVELS_FOLDER = "levels"
CASE_TEXT_NAME = "case.toml"
RESULT_NAME = "refinement.nc"
MAX_WINDOW_MOVES = 3
"""A level's window grows at most this many times before the level is given up."""
WINDOW_BELOW, WINDOW_ABOVE = 2, 2
"""A later level's window reaches this many steps d below and above its predicted FOS."""
FIRST_CHANGE = 0.015
"""The change of the FOS from the first level to the second, a fraction of the first's, before
two levels have measured one."""
REPEAT_LEVEL = 1
"""The level repeated with another jitter seed to measure the scatter."""
REPEAT_SEED_OFFSET = 1000


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
    folder: str = ""  # under OUT/levels/


@dataclass
class RefinementOutcome:
    """What a refinement study did and found."""

    out_dir: Path
    result_path: Path
    levels: list[LevelResult]
    band: DiscretisationBand | None  # None: fewer than MIN_LEVELS levels have an FOS
    repeat: LevelResult | None = None  # the repeated level (the scatter), if made
    stop_reason: str = ""
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)
    message: str = ""  # why there is no band

    @property
    def measured_scatter(self) -> float:
        """|F_1 - F_1'| / sqrt 2 (0 when not measured)."""
        if self.repeat is None or len(self.levels) <= REPEAT_LEVEL:
            return 0.0
        first, again = self.levels[REPEAT_LEVEL].fos, self.repeat.fos
        return abs(first - again) / math.sqrt(2.0) if math.isfinite(first) and math.isfinite(again) else 0.0

    @property
    def verdict(self) -> str:
        """The report's first line: the FOS as h -> 0 with its uncertainty, or why there is none."""
        b = self.band
        if b is None:
            return f"no FOS at h -> 0: {self.message}"
        trust = "" if b.trusted else " (band not to be trusted: see below)"
        return (f"FOS = {b.fos:.4f} +- {b.uncertainty:.4f} (95%, +-{100 * b.relative_uncertainty:.2g}%) at h -> 0, "
                f"band [{b.band_low:.4f}, {b.band_high:.4f}] from {len(self.found_levels)} levels{trust}")

    @property
    def found_levels(self) -> list[LevelResult]:
        return [level for level in self.levels if math.isfinite(level.fos)]


def predicted_fos(spacings_m: list[float], fos: list[float], next_spacing_m: float) -> tuple[float, float]:
    """(predicted FOS, expected change) of the next level from the levels so far (coarsest first):
    with one level, a fall of ``FIRST_CHANGE``; with more, first-order convergence through the last two,
    F_next = F_k + (F_k - F_(k-1)) (h_next - h_k) / (h_k - h_(k-1))."""
    if len(fos) == 1:
        change = -FIRST_CHANGE * fos[0]
    else:
        change = (fos[-1] - fos[-2]) * (next_spacing_m - spacings_m[-1]) / (spacings_m[-1] - spacings_m[-2])
    return fos[-1] + change, abs(change)


def window(fos: float, step: float) -> tuple[float, float, float]:
    """(srf_min, srf_max, srf_step) of a later level around its predicted FOS."""
    step = max(round(step, 4), 0.001)
    low = max(round(fos - WINDOW_BELOW * step, 4), 0.01)
    return low, round(low + (WINDOW_BELOW + WINDOW_ABOVE) * step, 4), step


@dataclass
class _Level:
    """A level planned: its study, and the zones that a later adaptive level keeps."""

    spacing_m: float
    study: Study
    zones: list = field(default_factory=list)  # [(polygon, spacing_m)], an adaptive level's refined zones
    moves: int = 0
    seed: int = 0


class RefinementStudy(StudyType):
    """A study with ``[refinement]`` (module doc)."""

    placement = Placement(gravity_in_process=True, figures=False, quiet_cases=True, keep_going=False, rounds=True)
    label = "a refinement study"
    base_note = ""

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.refinement is not None

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.table = study.refinement
        self.spacings = self.table.spacings(study.geometry.spacing_m)
        self.levels: list[_Level] = [self._plan(0, self.spacings[0], [], None)]
        self.repeat: _Level | None = None
        self.found: dict[int, FosOutcome] = {}  # the outcome of each level done
        self.repeat_outcome = None
        self.pending: dict[str, tuple[int, bool]] = {}  # case id -> (level, repeated) of the cases computing
        self.stop_reason = ""

    # ---- the levels' studies

    def _plan(self, k: int, spacing_m: float, zones: list, search, seed_offset: int = 0) -> _Level:
        seed = self.study.geometry.seed + k + seed_offset
        return _Level(spacing_m, self._level_study(k, spacing_m, zones, search, seed), zones, seed=seed)

    def _level_study(self, k: int, spacing_m: float, zones: list, search: tuple[float, float, float] | None,
                     seed: int) -> Study:
        """Level k's own study: the study at ``spacing_m`` (uniform) or with the refined ``zones``
        (adaptive), the levels' tolerance and jitter, a seed, and for a later level the SRF window
        ``search`` = (srf_min, srf_max, srf_step)."""
        raw = _loads(self.study.source_text)
        raw.pop("refinement", None)
        if zones:
            raw.setdefault("geometry", {}).setdefault("refined", []).extend(
                {"name": f"band_{i}", "region_m": [[round(float(x), 4), round(float(y), 4)] for x, y in polygon],
                 "spacing_m": h} for i, (polygon, h) in enumerate(zones))
        stage = self.study.strength_reduction.name
        values = {"geometry.spacing_m": self.study.geometry.spacing_m if self.table.adaptive else spacing_m,
                  "geometry.jitter": self.table.jitter, "geometry.seed": seed,
                  f"stages.{stage}.fos_tolerance": self.table.fos_tolerance}
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

    def _case_id(self, k: int, repeat: bool = False) -> str:
        h = self.levels[k].spacing_m if k < len(self.levels) else self.spacings[k]
        return f"level {k} (h = {h:g} m){' repeated' if repeat else ''}"

    def folder(self, k: int, repeat: bool = False) -> Path:
        h = self.levels[k].spacing_m if k < len(self.levels) else self.spacings[k]
        return self.out_dir / LEVELS_FOLDER / f"{k}_h={h:g}{'_repeat' if repeat else ''}"

    def _case(self, k: int, repeat: bool = False) -> Case:
        folder = self.folder(k, repeat)
        make_output_folder(folder)
        level = self.repeat if repeat else self.levels[k]
        write_text_if_changed(folder / CASE_TEXT_NAME, level.study.source_text)
        case_id = self._case_id(k, repeat)
        self.pending[case_id] = (k, repeat)
        return Case(level.study, folder, case_id)

    # ---- the study type's protocol

    def check(self, options: RunOptions) -> None:
        """Each planned uniform level's resolution and the memory of the finest (an adaptive study's
        levels are not known before they run: its first level's, and ``max_particles`` particles
        for the memory); the scene and simulation of the first level, which its run builds only once
        its folder is written (what the scene refuses, a material region that holds no particle, must
        be refused before anything is)."""
        from workflows.scene import build_scene
        from workflows.stages.running import new_simulation

        processes = 1 + (0 if options.scheduler else options.workers)
        first = self.levels[0].study
        try:
            first.strength_reduction.check_resolution(first)
        except StudyError as error:
            raise StudyError("refinement", f"level 0 (h = {self.spacings[0]:g} m): {error}") from None
        new_simulation(first, build_scene(first))
        if self.table.adaptive:
            limit = options.max_memory_bytes if options.max_memory_bytes is not None else available_memory_bytes()
            need = self.table.max_particles * BYTES_PER_PARTICLE * processes
            if need > limit:
                raise StudyError("refinement.max_particles", f"{self.table.max_particles} particles need about "
                                 f"{need / GIB:.3g} GiB in {processes} processes, more than the {limit / GIB:.3g} GiB "
                                 "available; give a smaller budget")
            check_memory(first, processes=processes, limit_bytes=options.max_memory_bytes)
            return
        for k, h in enumerate(self.spacings[1:], start=1):
            study = self._level_study(k, h, [], None, 0)
            try:
                study.strength_reduction.check_resolution(study)
            except StudyError as error:
                raise StudyError("refinement", f"level {k} (h = {h:g} m): {error}") from None
            if k == len(self.spacings) - 1:
                check_memory(study, processes=processes, limit_bytes=options.max_memory_bytes)

    def warnings(self) -> list[str]:
        """Thin layers at the finest uniform level, or the first adaptive one (``workflows.layers``)."""
        study = self.levels[0].study if self.table.adaptive else self._level_study(
            len(self.spacings) - 1, self.spacings[-1], [], None, 0)
        return thin_layer_warnings(study)

    def cases(self) -> list[Case]:
        make_output_folder(self.out_dir)
        (self.out_dir / RESULT_NAME).unlink(missing_ok=True)  # a stopped study must not show an old one
        return [self._case(0)]

    def next_cases(self, outcomes: dict, progress) -> list[Case]:
        """The next level (and the repeat with it), or the current one in a grown window, or none when
        done (module doc, steps 2-4)."""
        done = {case_id: where for case_id, where in self.pending.items() if case_id in outcomes}
        self.pending = {case_id: where for case_id, where in self.pending.items() if case_id not in outcomes}
        more: list[Case] = []
        for case_id, (k, repeated) in done.items():
            outcome = outcomes[case_id].result  # (a diverged level stops the study: never Diverged)
            if repeated:
                self.repeat_outcome = outcome
                continue
            if math.isfinite(outcome.fos):
                progress.message(f"level {k}: h = {self.levels[k].spacing_m:g} m, {outcome.n_particles} particles: FOS "
                                 f"{outcome.fos:.4f} [{outcome.fos_low:.4f}, {outcome.fos_high:.4f}], "
                                 f"{len(outcome.runs)} runs")
                self.found[k] = outcome
                continue
            grown = self._grown(k, outcome, progress)
            if grown is None:
                self.stop_reason = f"level {k} (h = {self.levels[k].spacing_m:g} m) has no FOS: {outcome.verdict}"
                progress.message(f"warning: {self.stop_reason}")
                return []
            self.levels[k] = grown
            more.append(self._case(k))
        if more or self.pending:
            return more
        k = len(self.found)  # the next level
        stop = self._stop(k)
        if stop:
            self.stop_reason = stop
            return []
        level = self._next_level(k, progress)
        if level is None:
            return []
        self.levels.append(level)
        more = [self._case(k)]
        if k == REPEAT_LEVEL and self.table.jitter > 0.0:
            self.repeat = self._plan(k, level.spacing_m, level.zones, self._search_of(level), REPEAT_SEED_OFFSET)
            more.append(self._case(k, repeat=True))
        return more

    def _search_of(self, level: _Level):
        stage = level.study.strength_reduction
        return stage.srf_min, stage.srf_max, stage.srf_step

    def _grown(self, k: int, outcome, progress) -> _Level | None:
        """Level k in a window grown by its width towards its FOS; None when it cannot grow.  A run
        failed: the FOS lies below the window or its knee needs more runs below the first failure
        (at least two stable ones and the curve's upturn), so the window grows down; none failed: up."""
        level = self.levels[k]
        if k == 0 or level.moves >= MAX_WINDOW_MOVES:
            return None
        down = math.isfinite(outcome.status_high)
        stage = level.study.strength_reduction
        width = stage.srf_max - stage.srf_min
        low, high = (stage.srf_min - width, stage.srf_max) if down else (stage.srf_min, stage.srf_max + width)
        search = (max(round(low, 4), 0.01), round(high, 4), stage.srf_step)
        why = (f"no knee in [{stage.srf_min:g}, {stage.srf_max:g}] (the curve needs more runs below the first "
               f"failure, SRF {outcome.status_high:g})" if down else f"the FOS lies above SRF {stage.srf_max:g}")
        progress.message(f"level {k}: {why}: searching [{search[0]:g}, {search[1]:g}]")
        return dataclasses.replace(level, study=self._level_study(k, level.spacing_m, level.zones, search, level.seed),
                                   moves=level.moves + 1)

    def _stop(self, k: int) -> str:
        """Why no level k is made ("" to make it)."""
        if not self.table.adaptive:
            return "" if k < len(self.spacings) else f"the {len(self.spacings)} levels of spacings_m are done"
        if k >= self.table.max_levels:
            return f"max_levels = {self.table.max_levels} reached"
        if k >= MIN_LEVELS:
            band = self._band()
            if band is not None and band.trusted and band.relative_uncertainty <= self.table.target_uncertainty:
                return (f"the band is +-{100 * band.relative_uncertainty:.2g}%, within the target "
                        f"+-{100 * self.table.target_uncertainty:.2g}%")
        return ""

    def _band(self) -> DiscretisationBand | None:
        spacings = [self.levels[k].spacing_m for k in sorted(self.found)]
        fos = [self.found[k].fos for k in sorted(self.found)]
        if len(fos) < MIN_LEVELS:
            return None
        repeat = self.repeat_outcome
        scatter = 0.0
        if repeat is not None and math.isfinite(repeat.fos) and REPEAT_LEVEL in self.found:
            scatter = abs(repeat.fos - self.found[REPEAT_LEVEL].fos) / math.sqrt(2.0)
        resolution = max(0.5 * (self.found[k].fos_high - self.found[k].fos_low) for k in self.found)
        return discretisation_band(spacings, fos, scatter, resolution)

    def _next_level(self, k: int, progress) -> _Level | None:
        """Level k's plan: its spacing, zones (adaptive) and window; None when it cannot be made."""
        spacings_done = [self.levels[j].spacing_m for j in range(k)]
        fos_done = [self.found[j].fos for j in range(k)]
        spacing = self.spacings[k] if not self.table.adaptive else float(
            f"{self.study.geometry.spacing_m / self.table.spacing_ratio**k:.6g}")
        predicted, change = predicted_fos(spacings_done, fos_done, spacing)
        search = window(predicted, max(2.5 * self.table.fos_tolerance, 0.75 * change))
        zones = []
        if self.table.adaptive:
            zones = self._band_zones(k, spacing, progress)
            if zones is None:
                return None
        level = self._plan(k, spacing, zones, search)
        if self.table.adaptive:
            n = estimated_particles(level.study)
            if n > self.table.max_particles:
                self.stop_reason = (f"level {k} (h = {spacing:g} m) would hold about {n:.3g} particles, over "
                                    f"max_particles = {self.table.max_particles}")
                progress.message(f"refinement stops: {self.stop_reason}")
                return None
        return level

    def _band_zones(self, k: int, spacing_m: float, progress) -> list | None:
        """The zones of level k: those of level k - 1 and the outlines around its mechanism's band."""
        from workflows.fos.run_store import run_file_name  # dask: only when FOS cases run

        before = self.found[k - 1]
        stable = [r.srf for r in before.runs if r.status == "stable" and r.srf < before.status_high]
        failed_path = before.out_dir / run_file_name(before.status_high)
        stable_path = before.out_dir / run_file_name(max(stable)) if stable else None
        xy0, indicator = band_indicator(self.table.indicator, failed_path, stable_path)
        outlines = zone_outlines(band_particles(xy0, indicator), self.table.band_reach * self.levels[k - 1].spacing_m)
        if not outlines:
            self.stop_reason = f"level {k - 1}'s first failed run has no shear band to refine"
            progress.message(f"warning: {self.stop_reason}")
            return None
        return self.levels[k - 1].zones + [(outline, spacing_m) for outline in outlines]

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> RefinementOutcome:
        results = {case_id: outcome.result for case_id, outcome in outcomes.items()}
        levels = [self._level_result(k, results.get(self._case_id(k))) for k in range(len(self.levels))]
        levels = [level for level in levels if level is not None]
        repeat = self._level_result(REPEAT_LEVEL, results.get(self._case_id(REPEAT_LEVEL, True)), repeat=True) \
            if self.repeat is not None else None
        result = RefinementOutcome(self.out_dir, self.out_dir / RESULT_NAME, levels, None, repeat, self.stop_reason)
        found = result.found_levels
        if len(found) >= MIN_LEVELS:
            resolution = max(0.5 * (level.fos_high - level.fos_low) for level in found)
            result.band = discretisation_band([level.spacing_m for level in found], [level.fos for level in found],
                                              result.measured_scatter, resolution)
        else:
            result.message = f"{len(found)} levels have an FOS, at least {MIN_LEVELS} are needed" + (
                f" ({self.stop_reason})" if self.stop_reason else "")
        result.timings_s = {"levels_elapsed": timings.cases_elapsed, "total": time.perf_counter() - wall_start}
        dataset = refinement_dataset(self.study, result)
        write_dataset(dataset, result.result_path)
        if self.study.output.figures:
            result.figures = draw_convergence(self.out_dir, dataset)
        return result

    def _level_result(self, k: int, outcome, repeat: bool = False) -> LevelResult | None:
        if outcome is None:
            return None
        made = [run for run in outcome.runs if run.started_s == run.started_s]  # NaN: reused
        return LevelResult(
            self.levels[k].spacing_m, outcome.fos, outcome.fos_low, outcome.fos_high, outcome.n_particles,
            len(outcome.runs), len(made), outcome.timings_s["gravity"] + sum(run.wall_time_s for run in made),
            outcome.verdict, outcome.criteria_agree, self.folder(k, repeat).name)

    def report(self, outcome: RefinementOutcome, quiet: bool, study_file) -> Report:
        lines = [outcome.verdict]
        if quiet:
            return Report(lines)
        lines.append(f"{'level':>5}  {'h (m)':>8}  {'particles':>9}  {'FOS':>7}  {'bracket':>17}  runs")
        rows = list(enumerate(outcome.levels)) + ([(f"{REPEAT_LEVEL}'", outcome.repeat)] if outcome.repeat else [])
        for k, level in rows:
            lines.append(f"{k!s:>5}  {level.spacing_m:8.4g}  {level.n_particles:9d}  {level.fos:7.4f}  "
                         f"[{level.fos_low:.4f}, {level.fos_high:.4f}]  {level.n_runs:4d}")
        if outcome.band is not None:
            lines.append(outcome.band.reason)
        if outcome.repeat is not None:
            lines.append(f"level {REPEAT_LEVEL}' is level {REPEAT_LEVEL} with another jitter seed: measured scatter "
                         f"{outcome.measured_scatter:.4f}")
        if outcome.stop_reason:
            lines.append(f"stopped: {outcome.stop_reason}")
        lines.append(f"wall time {outcome.timings_s['total']:.1f} s; wrote {outcome.result_path}"
                     + "".join(f", {path.name}" for path in outcome.figures) + f", {self.out_dir / LEVELS_FOLDER}/")
        return Report(lines)
