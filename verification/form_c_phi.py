"""FORM, the FOSM index and the point estimate method against Monte Carlo on a c-phi slope with four
normal random variables (c', phi', unit weight, ru), every FOS at one spacing.

    python -m verification.form_c_phi                      # h = 1 m, 4,000 Monte Carlo realisations
    python -m verification.form_c_phi --spacing 0.5 --realisations 2000
    python -m verification.form_c_phi --sorm --form-only     # FORM then SORM's round, no PEM or Monte Carlo
    python -m verification.form_c_phi --sorm --form-only --sorm-step 2 --fos-tolerance 0.0005
    python -m verification.form_c_phi --form-only --subset-seeds 1 2 3   # and subset simulation, FORM's event

The slope is Li & Lumb's (1987) 45 deg slope at ru = 0.2 on its 5 m foundation
(``verification.fos_accuracy``: c' 18 kPa, phi' 30 deg, gamma 18 kN/m3), with c' normal of COV 0.2,
phi' normal of std 3 deg, gamma normal of COV 0.05 and ru normal of COV 0.1 (independent).  FORM and the
point estimate method search each point's FOS (``[probabilistic] method = "form"`` and
``"point_estimate"``, compute = "fos"); Monte Carlo judges each realisation by its run at F = 1 (verdict
mode), pf with its exact interval and beta = -Phi^-1(pf).  Printed: each method's beta, pf, the FOS
searches and SRF runs it cost, and its wall time.  With ``--sorm`` the FORM study runs SORM's round on its
design point (``sorm = true``) and a row each for Breitung's and Hohenbichler-Rackwitz's beta (the searches
and runs: the round's alone; its wall is the FORM row's, which then holds both).  ``--subset-seeds`` adds a
subset simulation per seed (``samples_per_level`` 200, p0 0.1, compute = "fos": FORM's event, FOS < 1, where
Monte Carlo's is the verdict of the run at F = 1), pf with its approximate 95% interval from its coefficient
of variation.
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


def study_text(spacing_m: float, method: str, realisations: int, compute: str, extra: str = "") -> str:
    """The slope at ``spacing_m`` with its four variables and ``[probabilistic]`` (``extra``: more of its fields)."""
    text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", c_phi_text("li_lumb_ru0.2"), count=1)
    return (text + f'\n[probabilistic]\nmethod = "{method}"\nrealisations = {realisations}\nseed = 1\n'
            f'compute = "{compute}"\nfactor = 1.0\n{extra}' + VARIABLES)


def _sorm_rows(out) -> None:
    """SORM's rows (``--sorm``), or the line saying why it has none: its round's searches, runs and the runs'
    wall time on the workers (``form_iteration`` -1 in ``probabilistic.nc``)."""
    import xarray as xr

    second = out.second_order
    if second is None or second.pf_breitung is None:
        print(f"| SORM | - | - | - | - | {'not run' if second is None else second.status} |", flush=True)
        return
    ds = xr.load_dataset(out.result_path)
    mine = ds["form_iteration"].values == -1
    runs, worker_s = int(ds["n_runs"].values[mine].sum()), float(ds["run_wall_time"].values[mine].sum())
    print(f"| SORM, Breitung (curvatures {', '.join(f'{k:+.4f}' for k in second.kappas)}, each +- {second.noise:.4f}) | "
          f"{second.beta_breitung:.3f} | {second.pf_breitung:.3g} | {second.searches} (sorm_step {second.step:g}) | "
          f"{runs} | {worker_s:.0f} on the workers |")
    print(f"| SORM, Hohenbichler-Rackwitz | {second.beta_hr:.3f} | {second.pf_hr:.3g} | (the same) | - | - |", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=1.0)
    parser.add_argument("--realisations", type=int, default=4000, help="Monte Carlo realisations")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sorm", action="store_true", help="FORM with SORM's round on its design point")
    parser.add_argument("--form-only", action="store_true", help="FORM (and SORM) only: no PEM, no Monte Carlo")
    parser.add_argument("--sorm-step", type=float, default=1.0, help="SORM's step (sorm_step)")
    parser.add_argument("--fos-tolerance", type=float, default=0.002, help="FORM's and SORM's searches' bracket")
    parser.add_argument("--subset-seeds", type=int, nargs="*", default=[], help="a subset simulation per seed")
    parser.add_argument("--samples-per-level", type=int, default=200, help="the subset simulations' level size")
    args = parser.parse_args(argv)
    options = RunOptions(workers=args.workers)
    print("| method | beta | pf | FOS searches | SRF runs | wall (s) |")
    print("|---|---|---|---|---|---|", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        form_fields = f"fos_tolerance = {args.fos_tolerance:g}\n" + (
            f"sorm = true\nsorm_step = {args.sorm_step:g}\n" if args.sorm else "")
        out = run_study(parse_study(study_text(args.spacing, "form", 60, "fos", form_fields)), Path(scratch) / "form",
                        options)
        print(f"| FOSM (mean value, FORM's first iteration) | {out.beta_fosm:.3f} | "
              f"{stats.norm.sf(out.beta_fosm):.3g} | 5 | - | - |")
        sorm_searches = 0 if out.second_order is None else out.second_order.searches
        with_sorm = " (with SORM's round)" if sorm_searches else ""
        print(f"| FORM (HL-RF, {out.iterations} iterations{'' if out.converged else ', NOT converged'}) | "
              f"{out.beta:.3f} | {stats.norm.sf(out.beta):.3g} | {out.n_searches - sorm_searches} | "
              f"{out.runs_made}{with_sorm} | {out.timings_s['total']:.0f}{with_sorm} |", flush=True)
        print("design point: " + ", ".join(f"{k} {v:.4g}" for k, v in out.design_point.items())
              + "; alpha: " + ", ".join(f"{k} {v:+.3f}" for k, v in out.alpha.items()), file=sys.stderr)
        if args.sorm:
            _sorm_rows(out)
            if out.second_order is not None:
                print(out.second_order.line(out.beta), file=sys.stderr)
        for seed in args.subset_seeds:
            text = study_text(args.spacing, "subset_simulation", 3000, "fos",
                              f"samples_per_level = {args.samples_per_level}\n").replace("seed = 1", f"seed = {seed}")
            out = run_study(parse_study(text), Path(scratch) / f"subset_{seed}", options)
            beta = [-stats.norm.ppf(p) for p in (out.pf, out.pf_high, out.pf_low)]
            print(f"| subset simulation (FOS < 1, seed {seed}, {len(out.thresholds) + 1} levels, cov {out.cov:.2f}) | "
                  f"{beta[0]:.3f} [{beta[1]:.3f}, {beta[2]:.3f}] | {out.pf:.3g} [{out.pf_low:.3g}, {out.pf_high:.3g}] | "
                  f"{out.n_searches} | {out.runs_made} | {out.timings_s['total']:.0f} |", flush=True)
        if args.form_only:
            return 0
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
