"""FORM, the FOSM index and the point estimate method against Monte Carlo on a c-phi slope with four
normal random variables (c', phi', unit weight, ru), every FOS at one spacing.

    python -m verification.form_c_phi                      # h = 1 m, 4,000 Monte Carlo realisations
    python -m verification.form_c_phi --spacing 0.5 --realisations 2000

The slope is Li & Lumb's (1987) 45 deg slope at ru = 0.2 on its 5 m foundation
(``verification.fos_accuracy``: c' 18 kPa, phi' 30 deg, gamma 18 kN/m3), with c' normal of COV 0.2,
phi' normal of std 3 deg, gamma normal of COV 0.05 and ru normal of COV 0.1 (independent).  FORM and the
point estimate method search each point's FOS (``[probabilistic] method = "form"`` and
``"point_estimate"``, compute = "fos"); Monte Carlo judges each realisation by its run at F = 1 (verdict
mode), pf with its exact interval and beta = -Phi^-1(pf).  Printed: each method's beta, pf, the FOS
searches and SRF runs it cost, and its wall time.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

from scipy import stats

from verification.fos_accuracy import c_phi_text
from workflows.cases import RunOptions
from workflows.study import parse_study
from workflows.study_types import run_study

VARIABLES = """
[[probabilistic.variables]]
path = "materials.soil.cohesion_kpa"
distribution = "normal"
cov = 0.2

[[probabilistic.variables]]
path = "materials.soil.friction_deg"
distribution = "normal"
std = 3.0

[[probabilistic.variables]]
path = "materials.soil.unit_weight_kn_m3"
distribution = "normal"
cov = 0.05

[[probabilistic.variables]]
path = "water.ru"
distribution = "normal"
cov = 0.1
"""


def study_text(spacing_m: float, method: str, realisations: int, compute: str) -> str:
    """The slope at ``spacing_m`` with its four variables and ``[probabilistic]``."""
    text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", c_phi_text("li_lumb_ru0.2"), count=1)
    return (text + f'\n[probabilistic]\nmethod = "{method}"\nrealisations = {realisations}\nseed = 1\n'
            f'compute = "{compute}"\nfactor = 1.0\n' + VARIABLES)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=1.0)
    parser.add_argument("--realisations", type=int, default=4000, help="Monte Carlo realisations")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    options = RunOptions(workers=args.workers)
    print("| method | beta | pf | FOS searches | SRF runs | wall (s) |")
    print("|---|---|---|---|---|---|", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        out = run_study(parse_study(study_text(args.spacing, "form", 60, "fos")), Path(scratch) / "form", options)
        print(f"| FOSM (mean value, FORM's first iteration) | {out.beta_fosm:.3f} | "
              f"{stats.norm.sf(out.beta_fosm):.3g} | 5 | - | - |")
        print(f"| FORM (HL-RF, {out.iterations} iterations{'' if out.converged else ', NOT converged'}) | "
              f"{out.beta:.3f} | {stats.norm.sf(out.beta):.3g} | {out.n_searches} | {out.runs_made} | "
              f"{out.timings_s['total']:.0f} |", flush=True)
        print("design point: " + ", ".join(f"{k} {v:.4g}" for k, v in out.design_point.items())
              + "; alpha: " + ", ".join(f"{k} {v:+.3f}" for k, v in out.alpha.items()), file=sys.stderr)
        out = run_study(parse_study(study_text(args.spacing, "point_estimate", 16, "fos")), Path(scratch) / "pem",
                        options)
        print(f"| point estimate (Rosenblueth; FOS mean {out.pem_mean:.4f}, std {out.pem_std:.4f}) | "
              f"{out.beta_normal:.3f} (normal FOS), {out.beta_lognormal:.3f} (lognormal) | "
              f"{stats.norm.sf(out.beta_normal):.3g} | {out.n_searches} | {out.runs_made} | "
              f"{out.timings_s['total']:.0f} |", flush=True)
        out = run_study(parse_study(study_text(args.spacing, "monte_carlo", args.realisations, "verdict")),
                        Path(scratch) / "mc", options)
        beta = [-stats.norm.ppf(p) for p in (out.pf, out.pf_high, out.pf_low)]
        print(f"| Monte Carlo (verdict at F = 1, {out.n_realisations} realisations, {out.n_failed} failed) | "
              f"{beta[0]:.3f} [{beta[1]:.3f}, {beta[2]:.3f}] | {out.pf:.3g} [{out.pf_low:.3g}, {out.pf_high:.3g}] | "
              f"- ({out.n_realisations} runs at F = 1) | {out.runs_made} | {out.timings_s['total']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
