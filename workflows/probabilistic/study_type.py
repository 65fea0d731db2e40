"""A probabilistic study: the study once per realisation of its random variables, and
``OUT/probabilistic.nc`` with the probability of failure.

1. The realisations (:class:`Realisations`): the values of ``[probabilistic]``'s variables, all
   drawn at once (``workflows.probabilistic.sampling``: Monte Carlo, realisation i from its own
   stream, or a Latin hypercube), each in the unit its path names (``materials.soil.cohesion_kpa``:
   kPa; ``unit_weight_kn_m3``: kN/m3, whichever spelling the study file uses for the field); in
   ``verdict`` mode the strength-reduction stage makes the one run at ``factor`` (``srf_min =
   srf_max = factor``).  Before anything is written (:meth:`ProbabilisticStudy.check`, which
   ``spfem-fos check`` runs too): the paths, means and spreads, the correlation, every draw against
   its field's range, realisations 0 and 1 as whole studies (random values that change nothing the
   study computes are refused: their realisations would be copies, not samples), the scene of
   realisation 0 (its random fields), its resolution and the memory.
2. A realisation's study (its values set at their paths, checked as a study file is) is made only
   when it is about to run, and its folder ``OUT/cases/realisation_<i>/`` with its ``case.toml``
   written then: the first two with the cases, the others as the case runner has room for them
   (``workflows.cases.CaseFeed``), or with ``pf_interval_width`` batch by batch.  So a study of
   100,000 realisations starts its first run as soon as a study of ten does, and one that stops
   early never makes the rest.  A draw that breaks a rule between fields (a density that makes
   the soil lighter than water) is refused when its realisation is made: ``spfem-fos check`` makes
   every realisation, and refuses it before the study starts.
3. They run as a sweep's cases do (``workflows.sweep.study_type``): on one cluster, every finished
   run reused by the next invocation, so that a Monte Carlo study extended from 200 to 1,000
   realisations computes only the 800 new ones (a finished realisation is read back from its run
   files without its gravity state).  Each keeps only what is asked of it
   (:meth:`ProbabilisticStudy._placed`, a ``fos.task.RunPolicy``): realisations that share a
   gravity state (only strengths random) relax it once into ``OUT/gravity/``, others keep theirs in
   memory only; a run file keeps the final particle state only as ``keep_fields`` and
   ``keep_fields_first`` say (in ``fos`` mode the failed runs of a realisation that did not fail
   lose theirs once it concludes); in ``verdict`` mode a run ends as soon as it has failed (past the
   failure displacement: its verdict can no longer change) and no ``summary.nc`` is written (the
   run file holds it all).  With ``pf_interval_width`` they go in batches of
   :data:`BATCH_REALISATIONS`, and the study stops after the batch that brings the 95% interval of
   pf within it.
4. ``OUT/probabilistic.nc`` (``workflows.output.variables.PROBABILISTIC_FILE``) is written last: pf
   with its exact 95% interval, and in ``fos`` mode the FOS statistics, the reliability index and
   each variable's rank correlation with the FOS; then the figures (``probabilistic.figures``).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from workflows import engineering_units
from workflows.cases import Case, CaseFeed, CaseTimings, Report, RunOptions
from workflows.fields import MAX_MAGNITUDE, NUMBER, check_value, specs
from workflows.fos.discretisation import note
from workflows.fos.prediction import Generations, WindowPredictor
from workflows.memory_guard import check_memory
from workflows.output.figures import remove_stale_figures
from workflows.output.writing import make_output_folder, write_dataset, write_text_if_changed
from workflows.probabilistic.kinds import Computation
from workflows.probabilistic.reliability import failure_probability
from workflows.probabilistic.sampling import Marginal, Sampler
from workflows.random_field.table import spread_problem
from workflows.scene import random_field_notes
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, _build_study, _loads, resolve_field, resolve_sweep_path, set_field
from workflows.study.toml_text import to_toml
from workflows.sweep.results import (
    ABOVE,
    BELOW,
    CASE_TEXT_NAME,
    CASES_FOLDER,
    FOUND,
    NO_KNEE,
    CaseResult,
    case_result,
    diverged_result,
)
from workflows.sweep.stale import remove_stale_cases
from workflows.sweep.study_type import SweepStudy

RESULT_NAME = "probabilistic.nc"
BATCH_REALISATIONS = 100
"""With ``pf_interval_width``, realisations go to the cluster in batches of this many, the interval
checked after each batch (the same batches whatever the workers: the stop is reproducible)."""
FIRST_REALISATIONS = 2
"""Realisations made with the cases (module doc, step 2): 0 and 1, which the checks make anyway."""
CASE_PREFIX = "realisation_"
GRAVITY_FOLDER = "gravity"
"""``OUT/gravity/``: the one gravity state of realisations that share it (random strengths only)."""
STABLE, FAILED, UNDECIDED = "stable", "failed", "undecided"
THETA_FIELDS = ("theta_x_m", "theta_y_m")


def variable_labels(study: Study) -> list[str]:
    """A name per random variable: its field's name, with the entry before it where two share one."""
    paths = [variable.path for variable in study.probabilistic.variables]
    last = [path.split(".")[-1] for path in paths]
    return [name if last.count(name) == 1 else "_".join(path.split(".")[-2:]) for name, path in zip(last, paths)]


class Realisations:
    """The realisations of a probabilistic study: every value drawn at once, a realisation's study made
    only when asked for (module doc, steps 1-2).  StudyError naming the field for a path, mean, spread,
    correlation or draw that cannot be."""

    def __init__(self, study: Study):
        table = study.probabilistic
        self.study = study
        raw = _loads(study.source_text)
        raw.pop("probabilistic", None)
        if not table.computation.searches:  # one run, at the factor
            stage = study.strength_reduction.name
            for name in ("srf_min", "srf_max"):
                node, key, _ = resolve_sweep_path(raw, f"stages.{stage}.{name}")
                node[key] = table.factor
        self.raw = raw
        self.count = table.realisations
        self.labels = variable_labels(study)
        self.width = max(5, len(str(self.count - 1)))
        self.specs = [self._resolved(k).spec for k in range(len(table.variables))]
        self.values = self._sampled()
        self._check_draws()

    def _resolved(self, k: int):
        try:
            return resolve_field(copy.deepcopy(self.raw), self.study.probabilistic.variables[k].path)
        except StudyError as error:
            raise StudyError(f"probabilistic.variables[{k}].path", str(error)) from None

    def _marginal(self, k: int):
        """Variable k's distribution, its mean and std in the unit of its path (the mean by default the
        field's value in the study file, whichever unit it is written in)."""
        variable = self.study.probabilistic.variables[k]
        where = f"probabilistic.variables[{k}]"
        found = self._resolved(k)
        if found.spec.kind is not NUMBER:
            raise StudyError(f"{where}.path", f"{variable.path} is not a number field")
        if variable.kind.by_bounds:
            low, high = variable.low, variable.high
            for name, bound in (("low", low), ("high", high)):
                try:
                    check_value(found.spec, bound)
                except ValueError as error:
                    raise StudyError(f"{where}.{name}", f"{variable.path} {error}") from None
            return Marginal(variable.kind, 0.5 * (low + high), (high - low) / math.sqrt(12.0), low, high)
        mean = variable.mean
        if mean is None:
            declared = specs(found.table)
            units = engineering_units.units_of(found.key, declared, self.raw)
            si_mean = engineering_units.si_value(found.node, found.key if units is None else units.si_field,
                                                 declared, self.raw)
            if si_mean is None or not math.isfinite(si_mean):
                raise StudyError(f"{where}.mean", f"{variable.path} is not given in the study file: give the mean")
            mean = si_mean / (1.0 if units is None else units.si_per_unit)
        std = variable.std if variable.std is not None else variable.cov * abs(mean)
        if variable.kind.positive and mean <= 0.0:
            raise StudyError(f"{where}.mean", f"a {variable.distribution} variable needs a mean > 0, got {mean:g}")
        problem = spread_problem(mean, std, variable.cov is not None)
        if problem is not None:
            raise StudyError(f"{where}.{problem[0]}", f"{variable.path}: {problem[1]}")
        for name in ("low", "high"):
            bound = getattr(variable, name)
            if bound is not None:
                try:
                    check_value(found.spec, bound)
                except ValueError as error:
                    raise StudyError(f"{where}.{name}", f"{variable.path} {error}") from None
        return Marginal(variable.kind, float(mean), float(std),
                        -math.inf if variable.low is None else variable.low,
                        math.inf if variable.high is None else variable.high)

    def _sampled(self) -> np.ndarray:
        """(realisations, variables): the values of every realisation (module doc, step 1)."""
        table = self.study.probabilistic
        if not table.variables:  # only a [random_field] varies
            return np.empty((self.count, 0))

        marginals = [self._marginal(k) for k in range(len(table.variables))]
        try:
            sampler = Sampler(marginals, None if table.correlation is None else np.array(table.correlation, float))
        except ValueError as error:
            raise StudyError("probabilistic.correlation", str(error)) from None
        return table.method_kind.draw(sampler, table.seed, self.count)

    def _check_draws(self) -> None:
        """Every draw against its field's range (in the unit of its path): StudyError naming the first
        realisation that draws a value the field refuses."""
        for k, (variable, spec) in enumerate(zip(self.study.probabilistic.variables, self.specs)):
            x = self.values[:, k]
            ok = np.isfinite(x) & (np.abs(x) <= MAX_MAGNITUDE)
            for op, bound in spec.bounds:
                ok &= {">": x > bound, ">=": x >= bound, "<": x < bound, "<=": x <= bound}[op]
            if ok.all():
                continue
            i = int(np.argmin(ok))
            try:
                check_value(spec, float(x[i]))
                problem = "is out of its range"
            except ValueError as error:
                problem = str(error)
            share = float(np.mean(~ok))
            raise StudyError(f"probabilistic.variables[{k}]", f"realisation {i} draws {x[i]:.6g} for {variable.path}, "
                             f"which {problem} ({share:.3g} of the {self.count} realisations do; bound the "
                             "distribution: lognormal, uniform or truncated_normal)")

    def case_id(self, i: int) -> str:
        return f"{CASE_PREFIX}{i:0{self.width}d}"

    def raw_of(self, i: int) -> dict:
        """The study dict of realisation ``i``: its values at their paths, its fields' realisation."""
        case_raw = copy.deepcopy(self.raw)
        if self.study.random_field is not None:
            case_raw["random_field"]["realisation"] = i
        for variable, value in zip(self.study.probabilistic.variables, self.values[i]):
            node, key, spec = resolve_sweep_path(case_raw, variable.path)
            set_field(node, key, check_value(spec, float(value)))
        return case_raw

    def study_of(self, i: int, text: bool = True) -> Study:
        """Realisation ``i`` as its own checked study (with its TOML text: ``text``); StudyError naming
        the realisation and the field a draw breaks."""
        case_raw = self.raw_of(i)
        try:
            case_study = _build_study(case_raw)
        except StudyError as error:
            raise StudyError("probabilistic", f"realisation {i}: {error}") from None
        if not text:
            return case_study
        return dataclasses.replace(case_study, source_text=to_toml(
            case_raw, header=f"realisation {i} of the probabilistic study {self.study.name}"))

    def case(self, i: int) -> SweepCase:
        """Realisation ``i`` as a case (:meth:`study_of`)."""
        return SweepCase(self.case_id(i), (i,), dict(zip(self.labels, map(float, self.values[i]))), self.study_of(i))


def realisation_cases(study: Study) -> list[SweepCase]:
    """Each realisation as its own checked study (module doc, step 1), all at once."""
    realisations = Realisations(study)
    return [realisations.case(i) for i in range(realisations.count)]


@dataclass
class ProbabilisticOutcome:
    """What a probabilistic study did and found."""

    out_dir: Path
    result_path: Path
    n_realisations: int
    n_failed: int
    n_undecided: int  # gravity diverged, or no verdict
    pf: float
    pf_low: float
    pf_high: float
    fos_mean: float = math.nan
    fos_std: float = math.nan
    runs_made: int = 0
    timings_s: dict[str, float] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)
    n_mechanisms: int = 0  # failed realisations whose mechanism was extracted (their run files keep particles)
    edge_fractions: list = field(default_factory=list)  # (where, fraction of n_mechanisms, a warning) per support

    @property
    def verdict(self) -> str:
        """The report's first line."""
        decided = self.n_realisations - self.n_undecided
        line = (f"pf = {self.pf:.4g}, 95% interval [{self.pf_low:.4g}, {self.pf_high:.4g}]: {self.n_failed} of "
                f"{decided} realisations failed")
        if self.n_undecided:
            line += f" ({self.n_undecided} undecided, left out)"
        if math.isfinite(self.fos_mean):
            line += f"; FOS mean {self.fos_mean:.4g}, std {self.fos_std:.4g}"
        return line


def realisation_verdict(result: CaseResult, computation: Computation, factor: float) -> str:
    """STABLE, FAILED or UNDECIDED: the run at ``factor`` (verdict) or the FOS against it (fos)."""
    if not computation.searches:
        return {ABOVE: STABLE, BELOW: FAILED}.get(result.status, UNDECIDED)
    if result.status == FOUND:
        return FAILED if result.fos < factor else STABLE
    if result.status in (ABOVE, NO_KNEE) and result.fos_low >= factor:  # (no knee: the verdicts' bracket)
        return STABLE
    if result.status in (BELOW, NO_KNEE) and result.fos_high <= factor:
        return FAILED
    return UNDECIDED


@dataclass(frozen=True)
class RealisationRow:
    """A realisation as ``probabilistic.nc`` lists it: its folder, its number, its values."""

    case_id: str
    position: tuple[int]
    values: dict


LARGEST_GENERATION = 32
"""fos mode: realisations are predicted in generations of 1, 2, 4, ... up to this many (``fos.prediction``):
a larger generation leaves fewer waits for its last realisation, predicted from fewer others."""


class ProbabilisticStudy(SweepStudy):
    """A study with ``[probabilistic]`` (module doc)."""

    label = "a probabilistic study"
    base_note = "; the base study, before its random variables are drawn"

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.tally = {FAILED: 0, STABLE: 0, UNDECIDED: 0}  # verdicts of the realisations concluded so far
        self.realisations: Realisations | None = None  # (made by check)
        self.first: list[SweepCase] = []  # realisations 0 and 1, made by check
        self.shared_gravity: bool | None = None  # do all realisations share one gravity state (known by check)
        self.next_index = 0  # the next realisation to make
        self.batch_end = 0  # realisations are made up to here in this round (the batch of pf_interval_width)
        self.slip_lines: dict[str, tuple] = {}  # case id -> the slip line (x, y) of a failed realisation
        self.edges_reached: dict[str, list] = {}  # case id -> the supports its mechanism reaches (failed ones)
        self.study_of: dict[str, Study] = {}  # case id -> its study, until it concludes
        self.generation_windows: tuple[Generations, WindowPredictor] | None = None  # fos mode: (Generations, WindowPredictor) of the realisations' searches
        self.n_concluded = 0
        if not study.probabilistic.computation.searches:  # one run per realisation: its run file is its summary
            self.placement = dataclasses.replace(self.placement, summaries=False)
        if study.probabilistic.pf_interval_width is not None:
            self.placement = dataclasses.replace(self.placement, rounds=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.probabilistic is not None

    @property
    def fos(self) -> bool:
        return True

    def check(self, options: RunOptions) -> None:
        """What the study must pass before anything is written (module doc, step 1): StudyError naming the
        field, or the realisation and the field."""
        from workflows.fos.keys import gravity_key  # the core (numba): once the study is known to be valid

        self.realisations = realisations = self.make_realisations()
        self.first = [realisations.case(i) for i in range(min(FIRST_REALISATIONS, realisations.count))]
        self._check_each_variable_changes_something()
        self.shared_gravity = len({gravity_key(case.study) for case in self.first}) == 1
        study = self.first[0].study
        study.strength_reduction.check_resolution(study)
        check_memory(study, processes=self.processes(options), limit_bytes=options.max_memory_bytes)
        self._check_scenes()

    def make_realisations(self) -> Realisations:
        """The realisations (module doc, step 1), or the first points of a method that places them
        (``probabilistic.design_points``)."""
        return Realisations(self.study)

    def processes(self, options: RunOptions) -> int:
        """The local workers, and this process when it relaxes the one gravity state of every realisation."""
        workers = 0 if options.scheduler else options.workers
        return max(1, workers + (1 if self.shared_gravity else 0))

    def _check_each_variable_changes_something(self) -> None:
        """StudyError on a random variable whose values change nothing the study computes (realisation 0
        with that variable's value of realisation 1 has realisation 0's ``case_key``): its realisations
        would be one computation counted as independent samples."""
        from workflows.fos.keys import case_key  # the core (numba): once the study is known to be valid

        realisations = self.realisations
        if len(self.first) < 2:
            return
        key = case_key(self.first[0].study)
        for k, variable in enumerate(self.study.probabilistic.variables):
            if realisations.values[0, k] == realisations.values[1, k]:
                continue
            raw = realisations.raw_of(0)
            node, name, spec = resolve_sweep_path(raw, variable.path)
            set_field(node, name, check_value(spec, float(realisations.values[1, k])))
            try:
                other = _build_study(raw)
            except StudyError:
                continue  # that value breaks a rule of realisation 0's: it changes something
            if case_key(other) == key:
                raise StudyError(f"probabilistic.variables[{k}].path", f"{variable.path} changes nothing the study "
                                 "computes: realisations that differ in it are copies of one computation, not "
                                 "independent samples; make a field that enters the analysis random")

    def _check_scenes(self) -> None:
        """The scene and simulation of realisation 0 (its random fields, what the core refuses), and of the
        realisation with the longest scale of fluctuation a random variable draws."""
        from workflows.scene import build_scene  # the core (numba): once the study is known to be valid
        from workflows.stages.running import new_simulation

        studies = [self.first[0].study]
        for k, variable in enumerate(self.study.probabilistic.variables):
            parts = variable.path.split(".")
            if parts[0] == "random_field" and parts[-1] in THETA_FIELDS:
                studies.append(self.realisations.study_of(int(np.argmax(self.realisations.values[:, k])), text=False))
        for study in studies:
            new_simulation(study, build_scene(study))

    def check_every_case(self) -> None:
        """Every realisation made as the run would make it (``spfem-fos check``: the run makes each only
        when it is about to run, module doc, step 2)."""
        for i in range(len(self.first), self.realisations.count):
            self.realisations.study_of(i, text=False)

    def cases(self) -> list[Case]:
        """The first realisations (module doc, step 2); case folders of an earlier invocation that this
        study does not have removed, and its ``probabilistic.nc``."""
        (self.out_dir / RESULT_NAME).unlink(missing_ok=True)  # a stopped study must not show an old one
        make_output_folder(self.out_dir / CASES_FOLDER)
        realisations = self.realisations
        keep = {realisations.case_id(i) for i in range(realisations.count)}
        self.stale_cases = remove_stale_cases(self.out_dir / CASES_FOLDER, keep=keep)
        if self.shared_gravity:  # its one gravity state relaxes on all cores while the cluster starts
            self.placement = dataclasses.replace(self.placement, gravity_in_process=True)
        width = self.study.probabilistic.pf_interval_width
        self.batch_end = realisations.count if width is None else min(BATCH_REALISATIONS, realisations.count)
        return self.more_cases(FIRST_REALISATIONS)

    def more_cases(self, count: int) -> list[Case]:
        """Up to ``count`` more realisations of this round, each made and its ``case.toml`` written (module
        doc, step 2); in fos mode, generation by generation, each searched in a window about its predicted
        FOS (``fos.prediction``: from the realisations of the earlier generations)."""
        if self.study.probabilistic.computation.searches:
            if self.generation_windows is None:
                self.generation_windows = (Generations(self.realisations.count, LARGEST_GENERATION), WindowPredictor())
            generations, _ = self.generation_windows
            self._observe(generations.released(self.n_concluded))
            count = min(count, generations.room(self.n_concluded))
        cases: list[Case] = []
        while len(cases) < count and self.next_index < self.batch_end:
            i = self.realisation_at(self.next_index)
            case = self.first[i] if i < len(self.first) else self.realisations.case(i)
            self.next_index += 1
            folder = self.out_dir / CASES_FOLDER / case.case_id
            make_output_folder(folder)
            write_text_if_changed(folder / CASE_TEXT_NAME, case.study.source_text)
            self.study_of[case.case_id] = case.study
            made = self._placed(Case(case.study, folder, case.case_id, case.position, case.values))
            if self.generation_windows is not None:
                generations, windows = self.generation_windows
                generations.take(1)
                made = windows.with_window(made, self.features(made), self._field_estimate(made.study))
            cases.append(made)
        return cases

    def realisation_at(self, position: int) -> int:
        """The realisation made at ``position`` of the order the study hands them out in (here their own; subset
        simulation's level 0 hands out its lowest predicted first)."""
        return position

    def features(self, case: Case) -> list[float]:
        """A realisation's numbers for the prediction of its FOS: its random variables (a friction angle as
        its tangent); its random fields enter through its limit-equilibrium estimate
        (:meth:`_field_estimate`)."""
        return [math.tan(math.radians(float(value))) if variable.path.endswith("_deg") else float(value)
                for variable, value in zip(self.study.probabilistic.variables, case.values.values())]

    def _field_estimate(self, study: Study) -> float | None:
        """With random fields, the realisation's limit-equilibrium estimate through its fields
        (``probabilistic.field_mechanisms.FieldCircles``: the least over the circles of the mean soil of
        each one's F times its fields' mean strength along it over their mean); None without random
        fields (the critical circle's F)."""
        if study.random_field is None:
            return None
        if getattr(self, "_circles", None) is None:
            from workflows.probabilistic.field_mechanisms import FieldCircles  # the core (numba): on use

            self._circles = FieldCircles(self.study)
        return self._circles.estimate(study)

    def feed(self) -> CaseFeed:
        return CaseFeed(self.more_cases, lambda: self.batch_end - self.next_index)

    def _placed(self, case: Case) -> Case:
        """A realisation with what its runs keep and where its gravity state lives (module doc, step 3)."""
        from workflows.fos.task import RunPolicy  # dask: only when FOS cases run

        table = self.study.probabilistic
        first = case.position[0] < table.keep_fields_first
        policy = RunPolicy(fields="all" if first else table.keep_fields, stop_at_failure=not table.computation.searches)
        if self.shared_gravity:
            return dataclasses.replace(case, gravity_dir=self.out_dir / GRAVITY_FOLDER, runs=policy)
        return dataclasses.replace(case, write_gravity=False, runs=policy)

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        """The running tally: realisations failed so far and pf; in fos mode, the failed runs of a
        realisation that did not fail lose their particle state (``keep_fields = "failed"``: only the
        mechanisms of failed realisations are kept)."""
        table = self.study.probabilistic
        tally = self.tally
        if self.generation_windows is not None:
            self.n_concluded += 1
            self.generation_windows[0].hold(int(case_id[len(CASE_PREFIX):]), (case_id, outcome.fos))
        result = diverged_result("", 0) if outcome.diverged else case_result(outcome.result)
        verdict = realisation_verdict(result, table.computation, table.factor)
        tally[verdict] += 1
        index = int(case_id[len(CASE_PREFIX):])
        if (table.computation.searches and table.keep_fields == "failed" and verdict != FAILED
                and index >= table.keep_fields_first and not outcome.diverged):
            from workflows.fos.run_store import run_file_name, without_particle_fields  # dask: only when FOS cases run

            for record in outcome.runs:
                if record.status == FAILED:
                    without_particle_fields(outcome.result.out_dir / run_file_name(record.srf))
        if verdict == FAILED and not outcome.diverged:
            line, edges = self._mechanism(case_id, outcome.result)
            if line is not None:
                self.slip_lines[case_id] = line
                self.edges_reached[case_id] = edges
        self.study_of.pop(case_id, None)
        decided = tally[FAILED] + tally[STABLE]
        progress.tally(f"{tally[FAILED]} failed" + (f", pf {tally[FAILED] / decided:.3g}" if decided else ""))

    def _observe(self, concluded: list) -> None:
        """A generation's realisations join the prediction once all of them have concluded
        (``fos.prediction.Generations.released``): their FOS."""
        _, windows = self.generation_windows
        for case_id, fos in concluded:
            windows.concluded(case_id, fos)

    def _mechanism(self, case_id: str, outcome) -> tuple[tuple | None, list]:
        """The slip line (x, y) of a failed realisation and the supports its mechanism reaches: its
        summary's, or in verdict mode those of its failed run alone (no stable run to subtract); (None,
        []) when its run file keeps no particles."""
        from workflows.fos.domain_edges import edge_contacts  # the core (numba): once the study is known to be valid
        from workflows.fos.run_store import run_file_name
        from workflows.fos.slip_surface import SlipSurface, run_particles, slip_surface

        slip, edges = getattr(outcome, "slip", None), getattr(outcome, "edges", [])
        if not isinstance(slip, SlipSurface):
            failed = sorted(record.srf for record in outcome.runs if record.status == FAILED)
            study = self.study_of[case_id]
            particles = run_particles(outcome.out_dir / run_file_name(failed[0]), study) if failed else None
            if particles is None:
                return None, []
            slip = slip_surface(study, particles, None, failed[0], math.nan, limit_equilibrium=False)
            edges = edge_contacts(study, particles, None,
                                  (slip.x_m, slip.y_m) if isinstance(slip, SlipSurface) else None)
        return ((slip.x_m, slip.y_m), edges) if isinstance(slip, SlipSurface) else (None, [])

    def edge_fractions(self, case_ids) -> list[tuple[str, float, bool]]:
        """(where, fraction, a warning) for each support some mechanism reaches: the fraction of the failed
        realisations with a mechanism (among ``case_ids``) whose mechanism reaches it
        (``domain_edges.EdgeContact``: where it is, whether the box decides there)."""
        with_mechanism = [case_id for case_id in case_ids if case_id in self.edges_reached]
        counts: dict[tuple[str, bool], int] = {}
        for case_id in with_mechanism:
            for key in {(contact.where, contact.warning) for contact in self.edges_reached[case_id]}:
                counts[key] = counts.get(key, 0) + 1
        return [(where, count / len(with_mechanism), warning) for (where, warning), count in sorted(counts.items())]

    def conclude(self, outcomes: dict, timings: CaseTimings, wall_start: float) -> ProbabilisticOutcome:
        # the core (numba): once the study is known to be valid
        from workflows.probabilistic.results import probabilistic_dataset

        table = self.study.probabilistic
        realisations = self.realisations
        indices = sorted(int(case_id[len(CASE_PREFIX):]) for case_id in outcomes)  # fewer: a study stopped early
        rows = [RealisationRow(realisations.case_id(i), (i,), dict(zip(realisations.labels,
                                                                       map(float, realisations.values[i]))))
                for i in indices]
        results = {}
        for row in rows:
            outcome = outcomes[row.case_id]
            results[row.case_id] = (diverged_result(f"the gravity stage diverged: {outcome.error}", 0)
                                    if outcome.diverged else case_result(outcome.result))
        verdicts = [realisation_verdict(results[row.case_id], table.computation, table.factor) for row in rows]
        n_failed, n_undecided = verdicts.count(FAILED), verdicts.count(UNDECIDED)
        decided = len(verdicts) - n_undecided
        pf, low, high = failure_probability(n_failed, decided) if decided else (math.nan, math.nan, math.nan)
        fos = np.array([results[row.case_id].fos for row in rows])
        found = fos[np.isfinite(fos)]
        result = ProbabilisticOutcome(self.out_dir, self.out_dir / RESULT_NAME, len(verdicts), n_failed, n_undecided,
                                      pf, low, high)
        if table.computation.searches and len(found) >= 2:
            result.fos_mean, result.fos_std = float(found.mean()), float(found.std(ddof=1))
        runs = [record for outcome in outcomes.values() for record in outcome.runs]
        made = [record for record in runs if record.started_s == record.started_s]  # NaN: reused
        result.runs_made = len(made)
        result.timings_s = {"cases_elapsed": timings.cases_elapsed, "srf_runs_worker": timings.srf_runs_worker,
                            "run_loops": sum(record.wall_time_s for record in made),
                            "remesh": sum(record.remesh_wall_s for record in made),
                            "total": time.perf_counter() - wall_start}
        case_runs = {row.case_id: list(outcomes[row.case_id].runs) for row in rows}
        slip_lines = [self.slip_lines[row.case_id] for row in rows if row.case_id in self.slip_lines]
        result.edge_fractions = self.edge_fractions([row.case_id for row in rows])
        result.n_mechanisms = len(slip_lines)
        dataset = probabilistic_dataset(self.study, rows, results, verdicts, result, case_runs, slip_lines)
        write_dataset(dataset, result.result_path)
        from workflows.probabilistic.figures import FIGURE_NAMES, draw_probabilistic_figures  # (matplotlib: on use)

        if self.study.output.figures:
            result.figures = draw_probabilistic_figures(self.out_dir, dataset, self.study, slip_lines)
        self.stale_figures = remove_stale_figures(self.out_dir, FIGURE_NAMES, keep={path.name for path in result.figures})
        return result

    def next_cases(self, outcomes: dict, progress) -> list:
        """The next batch while the pf interval is wider than ``pf_interval_width`` (its first
        realisations; the case runner asks for the others as it has room)."""
        table = self.study.probabilistic
        if table.pf_interval_width is None or self.batch_end >= self.realisations.count:
            return []
        failed, decided = self.tally[FAILED], self.tally[FAILED] + self.tally[STABLE]
        if decided:
            _, low, high = failure_probability(failed, decided)
            if high - low <= table.pf_interval_width:
                progress.message(f"the 95% interval of pf is {high - low:.3g} wide after {decided} realisations, "
                                 f"within pf_interval_width = {table.pf_interval_width:g}: done")
                return []
        self.batch_end = min(self.batch_end + BATCH_REALISATIONS, self.realisations.count)
        return self.more_cases(FIRST_REALISATIONS)

    def report(self, outcome: ProbabilisticOutcome, quiet: bool, study_file) -> Report:
        if quiet:
            return Report([outcome.verdict])
        table = self.study.probabilistic
        how = table.computation.how(table.factor)
        return Report([outcome.verdict,
                       f"{outcome.n_realisations} realisations ({table.method.replace('_', ' ')}, seed {table.seed}), "
                       f"each judged by {how}; {outcome.runs_made} SRF runs made, wall time "
                       f"{outcome.timings_s['total']:.1f} s",
                       *_edge_lines(outcome), *random_field_notes(self.study), _discretisation_line(self.study),
                       f"wrote {outcome.result_path}, {self.out_dir / 'cases'}/"
                       + "".join(f", {path.name}" for path in outcome.figures), *self.removed])


def _discretisation_line(study) -> str:
    """The expected discretisation excess of each realisation's FOS (``fos.discretisation``): a FOS too
    high makes pf too low."""
    return note(study, "each realisation's FOS") + "; a FOS too high makes pf too low"


def _edge_lines(outcome) -> list[str]:
    """Where the failed realisations' mechanisms meet the box, a line per support reached."""
    return [f"{'WARNING, the box decides: ' if warning else 'note: '}{100 * fraction:.0f}% of the "
            f"{outcome.n_mechanisms} failed realisations with a mechanism reach {where}"
            for where, fraction, warning in outcome.edge_fractions]
