"""A probabilistic study: the study once per realisation of its random variables, and
``OUT/probabilistic.nc`` with the probability of failure.

1. The realisations (:func:`realisation_cases`): the values of ``[probabilistic]``'s variables
   (``workflows.probabilistic.sampling``: Monte Carlo, realisation i from its own stream, or a
   Latin hypercube), each set into the study at its path and checked like the field itself; in
   ``verdict`` mode the strength-reduction stage makes the one run at ``factor``
   (``srf_min = srf_max = factor``).
2. They run as a sweep's cases do (``workflows.sweep.study_type``): on one cluster, in
   ``OUT/cases/realisation_<i>/``, every finished run reused by the next invocation, so that a
   Monte Carlo study extended from 200 to 1,000 realisations computes only the 800 new ones (a
   finished realisation is read back from its run files without its gravity state).  Each keeps
   only what is asked of it (:meth:`ProbabilisticStudy._placed`, a ``fos.task.RunPolicy``):
   realisations that share a gravity state (only strengths random) relax it once into
   ``OUT/gravity/``, others keep theirs in memory only; a run file keeps the final particle
   state only as ``keep_fields`` and ``keep_fields_first`` say (in ``fos`` mode the failed runs
   of a realisation that did not fail lose theirs once it concludes); in ``verdict`` mode a run
   ends as soon as it has failed (past the failure displacement: its verdict can no longer
   change) and no ``summary.nc`` is written (the run file holds it all).  With
   ``pf_interval_width`` they go in batches of :data:`BATCH_REALISATIONS`, and the study stops
   after the batch that brings the 95% interval of pf within it.
3. ``OUT/probabilistic.nc`` (``workflows.output.variables.PROBABILISTIC_FILE``) is written last: pf
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

from spfem_core.divergence import DivergenceError
from workflows.cases import Case, CaseTimings, Report
from workflows.output.figures import remove_stale_figures
from workflows.study import Study, StudyError
from workflows.study.reading import SweepCase, _build_study, _loads, resolve_sweep_path
from workflows.study.toml_text import to_toml
from workflows.sweep.results import ABOVE, BELOW, FOUND, CaseResult, case_result, diverged_result
from workflows.sweep.study_type import SweepStudy

RESULT_NAME = "probabilistic.nc"
BATCH_REALISATIONS = 100
"""With ``pf_interval_width``, realisations go to the cluster in batches of this many, the interval
checked after each batch (the same batches whatever the workers: the stop is reproducible)."""
CASE_PREFIX = "realisation_"
GRAVITY_FOLDER = "gravity"
"""``OUT/gravity/``: the one gravity state of realisations that share it (random strengths only)."""
STABLE, FAILED, UNDECIDED = "stable", "failed", "undecided"


def variable_labels(study: Study) -> list[str]:
    """A name per random variable: its field's name, with the entry before it where two share one."""
    paths = [variable.path for variable in study.probabilistic.variables]
    last = [path.split(".")[-1] for path in paths]
    return [name if last.count(name) == 1 else "_".join(path.split(".")[-2:]) for name, path in zip(last, paths)]


def sampled_values(study: Study) -> np.ndarray:
    """(realisations, variables): the values of every realisation (module doc, step 1)."""
    table = study.probabilistic
    if not table.variables:  # only a [random_field] varies
        return np.empty((table.realisations, 0))
    from workflows.probabilistic.sampling import Marginal, Sampler  # scipy.stats: only when sampling

    raw = _loads(study.source_text)
    marginals = []
    for k, variable in enumerate(table.variables):
        node, key, spec = resolve_sweep_path(copy.deepcopy(raw), variable.path)
        if spec.type != "number":
            raise StudyError(f"probabilistic.variables[{k}].path", f"{variable.path} is not a number field")
        mean = variable.mean if variable.mean is not None else node.get(key)
        if not isinstance(mean, (int, float)) or isinstance(mean, bool) or not math.isfinite(mean):
            raise StudyError(f"probabilistic.variables[{k}].mean", f"{variable.path} is not given in the study "
                             "file: give the mean")
        std = variable.std if variable.std is not None else (variable.cov or 0.0) * abs(mean)
        if variable.distribution == "lognormal" and mean <= 0.0:
            raise StudyError(f"probabilistic.variables[{k}].mean", f"a lognormal variable needs a mean > 0, got {mean:g}")
        marginals.append(Marginal(variable.distribution, float(mean), float(std),
                                  -math.inf if variable.low is None else variable.low,
                                  math.inf if variable.high is None else variable.high))
    try:
        sampler = Sampler(marginals, None if table.correlation is None else np.array(table.correlation, float))
    except ValueError as error:
        raise StudyError("probabilistic.correlation", str(error)) from None
    if table.method == "latin_hypercube":
        return sampler.latin_hypercube(table.seed, table.realisations)
    return sampler.monte_carlo(table.seed, range(table.realisations))


def realisation_cases(study: Study) -> list[SweepCase]:
    """Each realisation as its own checked study (module doc, step 1)."""
    from workflows.fields import check_value

    table = study.probabilistic
    raw = _loads(study.source_text)
    raw.pop("probabilistic", None)
    if table.compute == "verdict":
        stage = study.strength_reduction.name
        for name in ("srf_min", "srf_max"):
            node, key, _ = resolve_sweep_path(raw, f"stages.{stage}.{name}")
            node[key] = table.factor
    labels = variable_labels(study)
    values = sampled_values(study)
    width = max(5, len(str(table.realisations - 1)))
    cases = []
    for i, row in enumerate(values):
        case_raw = copy.deepcopy(raw)
        case_id = f"{CASE_PREFIX}{i:0{width}d}"
        if study.random_field is not None:
            case_raw["random_field"]["realisation"] = i
        for k, (variable, value) in enumerate(zip(table.variables, row)):
            node, key, spec = resolve_sweep_path(case_raw, variable.path)
            try:
                node[key] = check_value(spec, float(value))
            except ValueError as error:
                raise StudyError(f"probabilistic.variables[{k}]", f"realisation {i} draws {value:.6g} for "
                                 f"{variable.path}, which {error} (bound the distribution: lognormal, uniform or "
                                 "truncated_normal)") from None
        text = to_toml(case_raw, header=f"realisation {i} of the probabilistic study {study.name}")
        try:
            case_study = dataclasses.replace(_build_study(case_raw), source_text=text)
        except StudyError as error:
            raise StudyError("probabilistic", f"realisation {i}: {error}") from None
        cases.append(SweepCase(case_id, (i,), dict(zip(labels, (float(v) for v in row))), case_study))
    return cases


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


def realisation_verdict(result: CaseResult, compute: str, factor: float) -> str:
    """STABLE, FAILED or UNDECIDED: the run at ``factor`` (verdict) or the FOS against it (fos)."""
    if compute == "verdict":
        return {ABOVE: STABLE, BELOW: FAILED}.get(result.status, UNDECIDED)
    if result.status == FOUND:
        return FAILED if result.fos < factor else STABLE
    if result.status == ABOVE and result.fos_low >= factor:
        return STABLE
    if result.status == BELOW and result.fos_high <= factor:
        return FAILED
    return UNDECIDED


class ProbabilisticStudy(SweepStudy):
    """A study with ``[probabilistic]`` (module doc)."""

    def __init__(self, study: Study, out_dir: Path):
        super().__init__(study, out_dir)
        self.tally = {FAILED: 0, STABLE: 0, UNDECIDED: 0}  # verdicts of the realisations concluded so far
        self.waiting: list = []  # realisations of the later batches (pf_interval_width)
        self.shared_gravity: bool | None = None  # do all realisations share one gravity state (known with the cases)
        self.realisation_of: dict[str, int] = {}  # case id -> realisation number (known with the cases)
        self.slip_lines: dict[str, tuple] = {}  # case id -> the slip line (x, y) of a failed realisation
        self.edges_reached: dict[str, list] = {}  # case id -> the supports its mechanism reaches (failed ones)
        self.study_of: dict[str, Study] = {}  # case id -> its study (known with the cases)
        if study.probabilistic.compute == "verdict":  # one run per realisation: its run file is its summary
            self.placement = dataclasses.replace(self.placement, summaries=False)
        if study.probabilistic.pf_interval_width is not None:
            self.placement = dataclasses.replace(self.placement, rounds=True)

    @staticmethod
    def applies_to(study: Study) -> bool:
        return study.probabilistic is not None

    @property
    def fos(self) -> bool:
        return True

    def make_cases(self) -> list[SweepCase]:
        return realisation_cases(self.study)

    def case_concluded(self, case_id: str, outcome, progress) -> None:
        """The running tally: realisations failed so far and pf (identical realisations count once);
        in fos mode, the failed runs of a realisation that did not fail lose their particle state
        (``keep_fields = "failed"``: only the mechanisms of failed realisations are kept)."""
        table = self.study.probabilistic
        tally = self.tally
        result = (diverged_result("", 0) if isinstance(outcome, DivergenceError) else case_result(outcome))
        verdict = realisation_verdict(result, table.compute, table.factor)
        tally[verdict] += 1
        index = self.realisation_of[case_id]
        if (table.compute == "fos" and table.keep_fields == "failed" and verdict != FAILED
                and index >= table.keep_fields_first and not isinstance(outcome, DivergenceError)):
            from workflows.fos.run_store import run_file_name, without_particle_fields

            for record in outcome.runs:
                if record.status == FAILED:
                    without_particle_fields(outcome.out_dir / run_file_name(record.srf))
        if verdict == FAILED and not isinstance(outcome, DivergenceError):
            line, edges = self._mechanism(case_id, outcome)
            if line is not None:
                self.slip_lines[case_id] = line
                self.edges_reached[case_id] = edges
        decided = tally[FAILED] + tally[STABLE]
        progress.tally(f"{tally[FAILED]} failed" + (f", pf {tally[FAILED] / decided:.3g}" if decided else ""))

    def _mechanism(self, case_id: str, outcome) -> tuple[tuple | None, list]:
        """The slip line (x, y) of a failed realisation and the supports its mechanism reaches: its
        summary's, or in verdict mode those of its failed run alone (no stable run to subtract); (None,
        []) when its run file keeps no particles."""
        from workflows.fos.domain_edges import edge_contacts
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
            edges = edge_contacts(study, particles, None)
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
        from workflows.output.writing import write_dataset
        from workflows.probabilistic.reliability import failure_probability
        from workflows.probabilistic.results import probabilistic_dataset

        table = self.study.probabilistic
        self.sweep_cases = [case for case in self.sweep_cases if self.same_as[case.case_id] in outcomes]  # stopped early
        results = {}
        for case in self.sweep_cases:
            outcome = outcomes[self.same_as[case.case_id]]
            results[case.case_id] = (diverged_result(f"the gravity stage diverged: {outcome}", 0)
                                     if isinstance(outcome, DivergenceError) else case_result(outcome))
        verdicts = [realisation_verdict(results[case.case_id], table.compute, table.factor) for case in self.sweep_cases]
        n_failed, n_undecided = verdicts.count(FAILED), verdicts.count(UNDECIDED)
        decided = len(verdicts) - n_undecided
        pf, low, high = failure_probability(n_failed, decided) if decided else (math.nan, math.nan, math.nan)
        fos = np.array([results[case.case_id].fos for case in self.sweep_cases])
        found = fos[np.isfinite(fos)]
        result = ProbabilisticOutcome(self.out_dir, self.out_dir / RESULT_NAME, len(verdicts), n_failed, n_undecided,
                                      pf, low, high)
        if table.compute == "fos" and len(found) >= 2:
            result.fos_mean, result.fos_std = float(found.mean()), float(found.std(ddof=1))
        runs = [record for outcome in outcomes.values() if not isinstance(outcome, DivergenceError)
                for record in outcome.runs]
        made = [record for record in runs if record.started_s == record.started_s]  # NaN: reused
        result.runs_made = len(made)
        result.timings_s = {"cases_elapsed": timings.cases_elapsed, "srf_runs_worker": timings.srf_runs_worker,
                            "run_loops": sum(record.wall_time_s for record in made),
                            "remesh": sum(record.remesh_wall_s for record in made),
                            "total": time.perf_counter() - wall_start}
        case_runs = {case.case_id: ([] if isinstance(outcome := outcomes[self.same_as[case.case_id]], DivergenceError)
                                    else outcome.runs) for case in self.sweep_cases}
        slip_lines = [self.slip_lines[case.case_id] for case in self.sweep_cases if case.case_id in self.slip_lines]
        result.edge_fractions = self.edge_fractions([case.case_id for case in self.sweep_cases])
        result.n_mechanisms = len(slip_lines)
        dataset = probabilistic_dataset(self.study, self.sweep_cases, results, verdicts, result, case_runs, slip_lines)
        write_dataset(dataset, result.result_path)
        from workflows.probabilistic.figures import FIGURE_NAMES, draw_probabilistic_figures  # (matplotlib: on use)

        if self.study.output.figures:
            result.figures = draw_probabilistic_figures(self.out_dir, dataset, self.study, slip_lines)
        self.stale_figures = remove_stale_figures(self.out_dir, FIGURE_NAMES, keep={path.name for path in result.figures})
        return result

    def cases(self):
        """Every realisation, or with ``pf_interval_width`` the first batch (module doc)."""
        (self.out_dir / RESULT_NAME).unlink(missing_ok=True)  # a stopped study must not show an old one
        cases = [self._placed(case) for case in super().cases()]
        self.realisation_of = {case.case_id: case.position[0] for case in self.sweep_cases}
        self.study_of = {case.case_id: case.study for case in self.sweep_cases}
        if self.shared_gravity:  # its one gravity state relaxes on all cores while the cluster starts
            self.placement = dataclasses.replace(self.placement, gravity_in_process=True)
        if self.study.probabilistic.pf_interval_width is None:
            return cases
        self.waiting = cases[BATCH_REALISATIONS:]
        return cases[:BATCH_REALISATIONS]

    def _placed(self, case: Case) -> Case:
        """A realisation with what its runs keep and where its gravity state lives (module doc, step 2)."""
        from workflows.fos.keys import gravity_key
        from workflows.fos.task import RunPolicy

        table = self.study.probabilistic
        if self.shared_gravity is None:  # one gravity key for every realisation: random strengths only
            self.shared_gravity = len({gravity_key(each.study) for each in self.sweep_cases}) == 1
        first = case.position[0] < table.keep_fields_first
        policy = RunPolicy(fields="all" if first else table.keep_fields, stop_at_failure=table.compute == "verdict")
        if self.shared_gravity:
            return dataclasses.replace(case, gravity_dir=self.out_dir / GRAVITY_FOLDER, runs=policy)
        return dataclasses.replace(case, write_gravity=False, runs=policy)

    def next_cases(self, outcomes: dict, progress) -> list:
        """The next batch while the pf interval is wider than ``pf_interval_width``."""
        from workflows.probabilistic.reliability import failure_probability

        if not self.waiting:
            return []
        failed, decided = self.tally[FAILED], self.tally[FAILED] + self.tally[STABLE]
        if decided:
            _, low, high = failure_probability(failed, decided)
            if high - low <= self.study.probabilistic.pf_interval_width:
                progress.message(f"the 95% interval of pf is {high - low:.3g} wide after {decided} realisations, "
                                 f"within pf_interval_width = {self.study.probabilistic.pf_interval_width:g}: done")
                self.waiting = []
                return []
        batch, self.waiting = self.waiting[:BATCH_REALISATIONS], self.waiting[BATCH_REALISATIONS:]
        return batch

    def report(self, outcome: ProbabilisticOutcome, quiet: bool, study_file) -> Report:
        if quiet:
            return Report([outcome.verdict])
        table = self.study.probabilistic
        how = (f"the run at F = {table.factor:g}" if table.compute == "verdict"
               else f"its FOS against F = {table.factor:g}")
        return Report([outcome.verdict,
                       f"{outcome.n_realisations} realisations ({table.method.replace('_', ' ')}, seed {table.seed}), "
                       f"each judged by {how}; {outcome.runs_made} SRF runs made, wall time "
                       f"{outcome.timings_s['total']:.1f} s",
                       *_edge_lines(outcome), _discretisation_line(self.study),
                       f"wrote {outcome.result_path}, {self.out_dir / 'cases'}/"
                       + "".join(f", {path.name}" for path in outcome.figures), *self.removed])


def _discretisation_line(study) -> str:
    """The expected discretisation excess of each realisation's FOS (``fos.discretisation``): a FOS too
    high makes pf too low."""
    from workflows.fos.discretisation import note

    return note(study, "each realisation's FOS") + "; a FOS too high makes pf too low"


def _edge_lines(outcome) -> list[str]:
    """Where the failed realisations' mechanisms meet the box, a line per support reached."""
    return [f"{'WARNING, the box decides: ' if warning else 'note: '}{100 * fraction:.0f}% of the "
            f"{outcome.n_mechanisms} failed realisations with a mechanism reach {where}"
            for where, fraction, warning in outcome.edge_fractions]
