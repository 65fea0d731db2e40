"""The FOS against the soil's stiffness: the same slope at several Young's moduli and Poisson's ratios.

    python -m benchmarks.fos_stiffness                        # both cases, E = 10 ... 1000 MPa, nu = 0.2 ... 0.45
    python -m benchmarks.fos_stiffness --cases reference_slope --moduli-mpa 20 --declared

Each case is a shipped study file at the given spacing (default 0.5 m, 20 spacings over the 10 m
slopes) with every material's ``youngs_modulus_pa`` and ``poisson_ratio`` replaced, run by the
command (2 local workers, warm numba cache).  ``--declared`` adds a row per modulus with
``scale_stiffness = false``: the runs at the declared moduli (docs/method.md, section 9).
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

import xarray as xr

from verification.study_command import run_study_command

ROOT = Path(__file__).resolve().parents[1]
CASES = {"reference_slope": "studies/reference_slope.toml", "griffiths_lane_ex4": "studies/published/griffiths_lane_ex4.toml"}


def study_text(case: str, spacing_m: float, modulus_pa: float, poisson: float, declared: bool) -> str:
    text = (ROOT / CASES[case]).read_text()
    text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)
    text = re.sub(r"(?m)^youngs_modulus_pa = .*$", f"youngs_modulus_pa = {modulus_pa:g}", text)
    text = re.sub(r"(?m)^poisson_ratio = .*$", f"poisson_ratio = {poisson:g}", text)
    if declared:
        text = re.sub(r"(?m)^(srf_step = .*)$", r"\1\nscale_stiffness = false", text, count=1)
    return text


def run(case, spacing_m, modulus_pa, poisson, declared, scratch: Path) -> dict:
    text = study_text(case, spacing_m, modulus_pa, poisson, declared)
    out, wall = run_study_command(text, scratch / f"{case}_{modulus_pa:g}_{poisson:g}_{int(declared)}")
    with xr.open_dataset(out / "summary.nc") as summary:
        fos = summary["fos"]
        return dict(fos=float(fos), low=fos.attrs["fos_low"], high=fos.attrs["fos_high"],
                    agree=bool(fos.attrs["criteria_agree"]), factor=summary.attrs["srf_stiffness_factor"],
                    runs=summary.sizes["srf"], wall=wall)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--spacing-m", type=float, default=0.5)
    parser.add_argument("--moduli-mpa", nargs="+", type=float, default=[10.0, 20.0, 100.0, 1000.0])
    parser.add_argument("--poisson", nargs="+", type=float, default=[0.2, 0.3, 0.45])
    parser.add_argument("--declared", action="store_true", help="also run each modulus at the declared moduli (nu 0.3)")
    args = parser.parse_args(argv)
    print("| case | E (MPa) | nu | moduli | stiffness factor | FOS [bracket] | criteria agree | runs | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for case in args.cases:
            rows = [(e, nu, False) for e in args.moduli_mpa for nu in args.poisson]
            rows += [(e, 0.3, True) for e in args.moduli_mpa] if args.declared else []
            for e, nu, declared in rows:
                r = run(case, args.spacing_m, e * 1e6, nu, declared, Path(scratch))
                print(f"| {case} | {e:g} | {nu:g} | {'declared' if declared else 'scaled'} | {r['factor']:.3g} | "
                      f"{r['fos']:.4f} [{r['low']:.4f}, {r['high']:.4f}] | {'yes' if r['agree'] else 'no'} | "
                      f"{r['runs']} | {r['wall']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
