"""Random fields as a linear map of their standard normal vector xi (what subset simulation's Markov chains
move): the map gives the generator's own draw, a field moved by conditional sampling keeps the model's
statistics, ``random_field.combination`` is checked, and subset simulation on a random field reaches a
known small pf (a cheap limit state on the field in place of each point's FOS search)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from workflows.random_field.correlation import MARKOV
from workflows.random_field.embedding import (
    CELL_QUADRATURE_POINTS,
    ParticleField,
    cell_correlation,
    cell_covariance,
    variance_function,
)
from workflows.random_field.expansion import ExpandedField, SingleValueField
from workflows.random_field.values import standard_normals
from workflows.study import StudyError, parse_study

REPO = Path(__file__).resolve().parents[1]
UNDRAINED = (REPO / "studies" / "probabilistic_undrained.toml").read_text()


def _lattice(step: float = 0.5):
    x, y = np.meshgrid(np.arange(0.0, 6.0, step), np.arange(0.0, 4.0, step), indexing="ij")
    return x, y


@pytest.mark.parametrize("kind", ["embedding", "expansion", "single"])
def test_the_field_of_a_draws_standard_normals_is_that_draw(kind):
    """field_of(standard_normals(rng)) is the first field draw(rng) gives, bit for bit: the realisations of
    every study drawn before the map existed are unchanged."""
    x, y = _lattice()
    field = {"embedding": lambda: ParticleField(MARKOV, 1.0, 1.0, x.ravel(), y.ravel(), 0.5),
             "expansion": lambda: ExpandedField(MARKOV, 50.0, 50.0, x.ravel(), y.ravel(), 0.5),
             "single": lambda: SingleValueField(x.size)}[kind]()
    for seed in (1, 2):
        drawn = field.draw(np.random.default_rng(seed))[0]
        assert np.array_equal(field.field_of(field.standard_normals(np.random.default_rng(seed))), drawn)


def _chain_terms(start: int, moves: int, rho: float = 0.8) -> tuple:
    """The terms of a field moved ``moves`` times by conditional sampling from realisation ``start``'s, every
    candidate accepted (``subset.moved_terms``), the candidates numbered after ``start``."""
    from workflows.probabilistic import subset

    terms: tuple = ((start, 1.0),)
    for k in range(moves):
        terms = subset.moved_terms(terms, 100_000 + 10 * start + k, rho)
    return terms


def test_a_field_moved_by_conditional_sampling_keeps_its_mean_variance_and_correlogram():
    """1,500 chains, each moved three times (xi' = 0.8 xi + 0.6 eps, through ``combination``'s terms): the
    particles' mean about 0, their variance the cell's gamma(h, h) and their correlation at 0.5-1.5 m
    the cells' (cell_correlation), within the tolerances of the sampler's own test; and the moved field
    correlates with its start as rho^3."""
    x, y = _lattice()
    field = ParticleField(MARKOV, 1.0, 1.0, x.ravel(), y.ravel(), 0.5)
    gamma = variance_function(MARKOV, 0.5, 0.5, 1.0, 1.0)
    moved, start = [], []
    for chain in range(1500):
        moved.append(field.field_of(standard_normals(field, SimpleNamespace(seed=3, terms=lambda c=chain: _chain_terms(c, 3)),
                                                     "cu")))
        start.append(field.field_of(standard_normals(field, SimpleNamespace(seed=3, terms=lambda c=chain: ((c, 1.0),)),
                                                     "cu")))
    values = np.array(moved).reshape(-1, *x.shape) / math.sqrt(gamma)
    assert abs(values.mean()) < 0.03
    assert values.var(axis=0).mean() == pytest.approx(1.0, abs=0.04)
    for lag in (1, 2, 3):
        target = cell_correlation(MARKOV, 0.5, 0.5 * lag, 0.0, 1.0, 1.0)
        assert (values[:, :-lag, :] * values[:, lag:, :]).mean() == pytest.approx(target, abs=0.03)
        assert (values[:, :, :-lag] * values[:, :, lag:]).mean() == pytest.approx(target, abs=0.03)
    lagged = (np.array(moved) * np.array(start)).mean() / gamma
    assert lagged == pytest.approx(0.8**3, abs=0.03)


def _with_combination(rows: str) -> str:
    return UNDRAINED.replace("[random_field]\nseed = 1", f"[random_field]\nseed = 1\ncombination = {rows}")


@pytest.mark.parametrize("rows, field", [
    ("[[0, 0.8], [1, 0.5]]", "random_field.combination"),
    ("[[0, 0.8], [0, 0.6]]", "random_field.combination[1]"),
    ("[[-1, 1.0]]", "random_field.combination[0]"),
    ('[[0, "a"]]', "random_field.combination[0]"),
    ("[1.0]", "random_field.combination[0]"),
])
def test_a_combination_that_is_no_standard_normal_vector_is_one_line(rows, field):
    with pytest.raises(StudyError) as error:
        parse_study(_with_combination(rows))
    assert error.value.field == field
    assert parse_study(_with_combination("[[0, 0.8], [1, 0.6]]")).random_field.terms() == ((0, 0.8), (1, 0.6))


def _fake_outcome(fos: float):
    """A concluded case (``cases.Concluded``) whose search found ``fos``."""
    from workflows.cases import Concluded

    return Concluded(SimpleNamespace(runs=[], fos=fos, fos_low=fos - 1e-3, fos_high=fos + 1e-3, criteria_agree=True,
                                     knee_srf=math.nan, n_particles=0, verdict="", status_low=math.nan,
                                     status_high=math.nan))


def _seeded(text: str, seed: int) -> str:
    """The study with ``seed`` for its variables and its fields (the fields' streams follow [random_field]'s)."""
    return text.replace("seed = 1\ncompute", f"seed = {seed}\ncompute").replace("[random_field]\nseed = 1",
                                                                              f"[random_field]\nseed = {seed}")


def test_subset_simulation_on_a_random_field_reaches_a_known_small_pf(tmp_path):
    """The undrained random-field study (lognormal cu, theta = 10 m) at h = 2 m by subset simulation, each
    point's FOS replaced by a linear limit state of its field: L = the mean of the standard Gaussian field
    over eight particles, FOS = 1 + 0.1 (L / sd_L + 3) with sd_L exact from the cells' covariance, so pf =
    P(FOS < 1) = Phi(-3) = 1.35e-3 whatever the field's dimension (a half-space in xi, thousands of numbers
    moved at once).  Over three seeds each approximate 95% interval holds it, the chains accept a share
    of their candidates, and the points are the same when the study is made again from the same FOS."""
    from workflows.cases import RunOptions
    from workflows.distributions import lognormal_parameters
    from workflows.probabilistic import subset
    from workflows.probabilistic.subset_study import SubsetStudy
    from workflows.progress import Progress
    from workflows.random_field.values import particle_field
    from workflows.scene import cloud, field_values
    from workflows.study_types import study_type

    text = UNDRAINED.replace("spacing_m = 1.0", "spacing_m = 2.0").replace('compute = "verdict"', 'compute = "fos"')
    text = re.sub(r'(?m)^method = .*$', 'method = "subset_simulation"\nsamples_per_level = 200', text, count=1)
    text = text.replace("realisations = 200", "realisations = 3000")
    exact = 0.5 * math.erfc(3.0 / math.sqrt(2.0))
    mu_ln, sigma_ln = lognormal_parameters(50e3, 0.5)
    for seed in (1, 2, 3):
        kind = study_type(parse_study(_seeded(text, seed)), tmp_path / f"seed_{seed}")
        assert isinstance(kind, SubsetStudy)
        kind.check(RunOptions(workers=1))
        kind.cases()
        points = kind.realisations
        if seed == 1:  # the eight particles and the standard deviation of their mean, from the cells' covariance
            xy, spacing = cloud(points.study_of(0, text=False))
            chosen = np.linspace(0, len(xy) - 1, 8).astype(int)
            generator = particle_field(MARKOV, 10.0, 10.0, xy, spacing)
            step = generator.step_m
            lags = np.abs(np.subtract.outer(generator.ix[chosen], generator.ix[chosen])) * step, np.abs(
                np.subtract.outer(generator.iy[chosen], generator.iy[chosen])) * step
            covariance = [cell_covariance(MARKOV, 2.0, [tx], [ty], 10.0, 10.0, CELL_QUADRATURE_POINTS)[0, 0]
                          for tx, ty in zip(lags[0].ravel(), lags[1].ravel())]
            sd = math.sqrt(float(np.mean(covariance)))
        outcomes, progress, fos_of = {}, Progress(), {}
        while True:
            for i in range(len(outcomes), points.count):
                g = (np.log(field_values(points.study_of(i, text=False))["cohesion_pa"][chosen]) - mu_ln) / sigma_ln
                fos_of[i] = 1.0 + 0.1 * (g.mean() / sd + 3.0)
                outcomes[points.case_id(i)] = _fake_outcome(fos_of[i])
            if not kind.next_cases(outcomes, progress) and kind.finished:
                break
        levels = kind.levels
        assert levels[-1]["last"] and not kind.stop_reason and len(levels) in (3, 4, 5)
        p = subset.estimate(0.1, levels[-1]["fraction"], len(levels))
        cov = math.sqrt(sum(subset.level_cov(level["fraction"], 200, level["gamma"]) ** 2 for level in levels))
        low, high = subset.interval(p, cov)
        assert low <= exact <= high, (seed, p, cov)
        moved = [i for i in kind.level_of if kind.level_of[i] > 0]
        assert 0.2 < sum(i in kind.accepted for i in moved) / len(moved) < 0.95
        assert points.field_terms and all(i >= 200 for i in points.field_terms)
        last = max(points.field_terms)  # its case file names its fields' terms, and they sum to one
        assert f"combination = [[{points.field_terms[last][0][0]}, " in points.study_of(last).source_text
        assert sum(w * w for _, w in points.field_terms[last]) == pytest.approx(1.0, abs=1e-12)
    again = study_type(parse_study(_seeded(text, 3)), tmp_path / "again")
    again.check(RunOptions(workers=1))
    again.cases()
    while True:  # the same FOS for the same points: the same chains, point for point
        made = {again.realisations.case_id(i): _fake_outcome(fos_of[i]) for i in range(again.realisations.count)}
        if not again.next_cases(made, progress) and again.finished:
            break
    assert again.realisations.field_terms == points.field_terms and again.realisations.count == points.count


@pytest.mark.slow
def test_a_subset_study_on_a_random_field_resumes_without_a_run_and_the_same_pf(tmp_path):
    """The undrained random-field study at h = 2 m, factor 0.8, 20 points a level: run, then run again into the
    same folder: every point made again from the seeds, every run read back (none made) and the same pf and
    levels (before: the second invocation re-made runs and stopped with the engine waiting on no task)."""
    from workflows.cases import RunOptions
    from workflows.study_types import run_study

    text = UNDRAINED.replace("spacing_m = 1.0", "spacing_m = 2.0").replace('compute = "verdict"', 'compute = "fos"')
    text = re.sub(r'(?m)^method = .*$', 'method = "subset_simulation"\nsamples_per_level = 20', text, count=1)
    text = text.replace("realisations = 200", "realisations = 100").replace("factor = 1.0", "factor = 0.8")
    first = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    again = run_study(parse_study(text), tmp_path, RunOptions(workers=2))
    assert first.runs_made > 0 and again.runs_made == 0
    assert again.pf == first.pf and again.thresholds == first.thresholds and again.n_searches == first.n_searches
