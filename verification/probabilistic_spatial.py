"""pf of Griffiths & Fenton's undrained slope against the COV of a cu random field, for two scales
of fluctuation, beside the single-variable limit.

    python -m verification.probabilistic_spatial                         # COV 0.25-2, theta/H 0.5 and 2; 500 each
    python -m verification.probabilistic_spatial --covs 0.5 --thetas 0.5 --realisations 50

Each row is ``studies/probabilistic_undrained.toml`` with its lognormal cu field at the COV and the
isotropic scale of fluctuation theta = (theta / H) H, every realisation judged by its run at F = 1.
The single-variable column is the limit theta -> infinity, one cu per realisation, in closed form
pf = Phi((ln(mean cu / F_det) - mu_ln) / sigma_ln) from the project's deterministic F_det (which
``verification.probabilistic_closed_form`` checks against Monte Carlo).  Griffiths & Fenton (2004,
Fig. 10 and 12) find the field's pf below the single-variable one at small COV and above it at
large COV, approaching it as theta grows.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from verification.undrained_variants import add_common_arguments, deterministic_fos, field_text, shipped_text
from workflows.cases import RunOptions
from workflows.probabilistic.reliability import lognormal_strength_pf
from workflows.study import parse_study
from workflows.study_types import run_study

SLOPE_HEIGHT_M = 10.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--covs", nargs="+", type=float, default=[0.25, 0.5, 1.0, 2.0])
    parser.add_argument("--thetas", nargs="+", type=float, default=[0.5, 2.0], help="theta / H")
    parser.add_argument("--realisations", type=int, default=500)
    add_common_arguments(parser)
    args = parser.parse_args(argv)
    text = shipped_text(args.spacing)
    mean_cu = parse_study(text).materials[0].cohesion_pa
    options = RunOptions(workers=args.workers)
    with tempfile.TemporaryDirectory() as scratch:
        f_det = deterministic_fos(text, args.fos_tolerance, options, Path(scratch) / "det")
        print("| theta / H | COV | realisations | failed | pf [95% interval] | single-variable pf | wall (s) |")
        print("|---|---|---|---|---|---|---|", flush=True)
        for theta in args.thetas:
            for cov in args.covs:
                case = field_text(text, cov, theta * SLOPE_HEIGHT_M, args.realisations)
                outcome = run_study(parse_study(case), Path(scratch) / f"theta_{theta:g}_cov_{cov:g}", options)
                single = lognormal_strength_pf(mean_cu, cov, f_det)
                print(f"| {theta:g} | {cov:g} | {outcome.n_realisations - outcome.n_undecided} | {outcome.n_failed} | "
                      f"{outcome.pf:.3f} [{outcome.pf_low:.3f}, {outcome.pf_high:.3f}] | {single:.3f} | "
                      f"{outcome.timings_s['total']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
