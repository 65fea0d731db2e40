"""Monte Carlo pf against the closed form, on an undrained slope with one lognormal cu.

    python -m verification.probabilistic_closed_form                      # COV 0.25, 0.5, 1.0; 1,000 each
    python -m verification.probabilistic_closed_form --covs 0.5 --realisations 200

With phi = 0 and no spatial variation, the run of cu at F and the run of k cu at k F are the same
problem, so a realisation fails at F = 1 exactly where cu < cu_crit = mean cu / F_det, and

    pf = Phi((ln cu_crit - mu_ln) / sigma_ln),   sigma_ln^2 = ln(1 + COV^2), mu_ln = ln(mean) - sigma_ln^2 / 2.

F_det is the project's own FOS of the same study without ``[probabilistic]`` at the same spacing,
searched to ``--fos-tolerance``; each Monte Carlo pf is given with its exact 95% interval, which
must hold the closed form (``studies/probabilistic_undrained.toml`` with one lognormal cu instead of
its field, ``verification.undrained_variants``; 2 local workers).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from verification.undrained_variants import add_common_arguments, deterministic_fos, shipped_text, single_variable_text
from workflows.cases import RunOptions
from workflows.probabilistic.reliability import lognormal_strength_pf
from workflows.study import parse_study
from workflows.study_types import run_study


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--covs", nargs="+", type=float, default=[0.25, 0.5, 1.0])
    parser.add_argument("--realisations", type=int, default=1000)
    add_common_arguments(parser)
    args = parser.parse_args(argv)
    text = shipped_text(args.spacing)
    mean_cu = parse_study(text).materials[0].cohesion_pa
    options = RunOptions(workers=args.workers)
    with tempfile.TemporaryDirectory() as scratch:
        f_det = deterministic_fos(text, args.fos_tolerance, options, Path(scratch) / "det")
        print("| COV | realisations | failed | Monte Carlo pf [95% interval] | closed-form pf | holds | wall (s) |")
        print("|---|---|---|---|---|---|---|")
        for cov in args.covs:
            case = single_variable_text(text, cov, args.realisations)
            outcome = run_study(parse_study(case), Path(scratch) / f"cov_{cov:g}", options)
            exact = lognormal_strength_pf(mean_cu, cov, f_det)
            holds = outcome.pf_low <= exact <= outcome.pf_high
            print(f"| {cov:g} | {outcome.n_realisations - outcome.n_undecided} | {outcome.n_failed} | "
                  f"{outcome.pf:.4f} [{outcome.pf_low:.4f}, {outcome.pf_high:.4f}] | {exact:.4f} | "
                  f"{'yes' if holds else 'no'} | {outcome.timings_s['total']:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
