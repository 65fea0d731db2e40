"""Subset simulation against the closed form of the undrained slope with one lognormal cu per realisation,
at COVs that put pf near 1e-3 and 1e-4, over independent seeds.

    python -m verification.subset_closed_form                          # h = 2 m, 200 points a level, seeds 1-5
    python -m verification.subset_closed_form --spacing 1 --samples 500 --targets 1e-3
    python -m verification.subset_closed_form --field        # cu the study's field, theta beyond the section

``studies/probabilistic_undrained.toml`` without its field, cu one lognormal variable
(``verification.undrained_variants``), ``method = "subset_simulation"``, each point's FOS searched to
0.002.  For phi = 0 the FOS is proportional to cu, so pf = Phi((ln(mean cu / F_det) - mu_ln) / sigma_ln)
with the project's own F_det at the same spacing; the COV for a target pf solves that for sigma_ln.
Each row: subset simulation's pf with its coefficient of variation and approximate 95% interval, whether
the interval holds the closed form, the FOS searches and SRF runs it made (and how many of the searches
were a chain's candidate rejected by its one run at its level's threshold), the realisations crude Monte
Carlo would need for the same coefficient of variation, (1 - pf) / (pf cov^2), and the load average
before and after (the machine is shared).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import tempfile
from pathlib import Path

from scipy import optimize, stats

from verification.undrained_variants import deterministic_fos, field_text, shipped_text, single_variable_text
from workflows.cases import RunOptions
from workflows.probabilistic.reliability import lognormal_strength_pf
from workflows.study import parse_study
from workflows.study_types import run_study

SINGLE_VARIABLE_THETA_M = 1e6
"""--field: a scale of fluctuation over 100 times the 90 m section: the field is one value per realisation."""


def cov_for(target_pf: float, f_det: float) -> float:
    """The COV of cu whose closed-form pf is ``target_pf`` (module doc)."""
    return float(optimize.brentq(lambda cov: lognormal_strength_pf(1.0, cov, f_det) - target_pf, 0.01, 2.0))


def subset_text(text: str, cov: float, seed: int, samples: int, budget: int, field: bool = False) -> str:
    """One lognormal cu per point, by subset simulation on each point's FOS: a random variable, or (``field``)
    the study's cu field at a scale of fluctuation beyond the single-variable limit (one value per point, drawn
    and moved through the fields' standard normal vectors and ``random_field.combination``)."""
    if field:
        text = field_text(text, cov, SINGLE_VARIABLE_THETA_M, budget)
        text = text.replace("[random_field]\nseed = 1", f"[random_field]\nseed = {seed}")
    else:
        text = single_variable_text(text, cov, budget)
    text = re.sub(r'(?m)^method = .*$', f'method = "subset_simulation"\nsamples_per_level = {samples}', text, count=1)
    text = re.sub(r"(?m)^seed = 1$", f"seed = {seed}", text, count=1)
    return re.sub(r'(?m)^compute = .*$', 'compute = "fos"', text, count=1)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", nargs="+", type=float, default=[1e-3, 1e-4])
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5])
    parser.add_argument("--samples", type=int, default=200, help="FOS searches a level")
    parser.add_argument("--spacing", type=float, default=2.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--field", action="store_true", help="cu as the study's random field in its single-variable "
                        "limit (the fields' chains) instead of a random variable")
    args = parser.parse_args(argv)
    text = shipped_text(args.spacing)
    options = RunOptions(workers=args.workers)
    with tempfile.TemporaryDirectory() as scratch:
        f_det = deterministic_fos(text, 0.002, options, Path(scratch) / "det")
        print("| target pf | COV | seed | subset pf (cov) [approx. 95% interval] | closed form | holds | levels | "
              "FOS searches | SRF runs | of them one-run rejections | crude MC for this cov | wall (s) | load |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
        for target in args.targets:
            cov = cov_for(target, f_det)
            exact = lognormal_strength_pf(1.0, cov, f_det)
            for seed in args.seeds:
                case = subset_text(text, cov, seed, args.samples, 20 * args.samples, args.field)
                load_before = os.getloadavg()[0]
                out = run_study(parse_study(case), Path(scratch) / f"pf_{target:g}_seed_{seed}", options)
                crude = (1.0 - out.pf) / (out.pf * out.cov**2) if out.pf > 0 else math.inf
                holds = out.pf_low <= exact <= out.pf_high
                print(f"| {target:g} | {cov:.4f} | {seed} | {out.pf:.3g} ({out.cov:.2f}) [{out.pf_low:.3g}, "
                      f"{out.pf_high:.3g}] | {exact:.3g} | {'yes' if holds else 'NO'} | {len(out.thresholds) + 1} | "
                      f"{out.n_searches} | {out.runs_made} | {out.threshold_verdicts} | {crude:,.0f} | "
                      f"{out.timings_s['total']:.0f} | {load_before:.1f} -> {os.getloadavg()[0]:.1f} |",
                      flush=True)
    print(f"(beta of the targets: {', '.join(f'{-stats.norm.ppf(t):.2f}' for t in args.targets)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
