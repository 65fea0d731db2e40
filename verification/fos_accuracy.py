"""The FOS a study reports against the truth: every shipped published study, Taylor's chart, the
quickstart and homogeneous c-phi slopes of 10 to 40 deg, at the study's own settings and controlled
(adaptive refinement from H/10, with its band), against the reference and a rigorous upper bound.

    python -m verification.fos_accuracy                      # every case (about 30 min on 2 cores)
    python -m verification.fos_accuracy --cases reference_slope phi35_1h1v

Each case runs through the command (``python -m workflows.cli``, 2 local workers): first as shipped
(or, for the c-phi slopes, at H/10 and H/20), then with ``[refinement]`` (adaptive, from h = H/10).
Error = FOS / reference - 1.  "holds": the band [f0 - U, f0 + U] holds the reference; "below UB":
the controlled FOS f0 lies at or below the upper bound.  The upper bounds: the least circle
(``verification.least_circle``) for phi = 0, the least log spiral (``verification.log_spiral``) for a
homogeneous c-phi slope, the published ones otherwise.  The last columns give each level's excess
over f0 at H/10 and H/20 (the discretisation error a study without [refinement] carries).
"""

from __future__ import annotations

import argparse
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from verification.study_command import run_study_command
from verification.study_text import gravity_stage, slope_form, srf_stage, study_text

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Case:
    text: str  # the study file
    height_m: float
    reference: float
    reference_name: str
    upper_bound: float | None  # a rigorous upper bound on the collapse SRF, if one is known


def _shipped(path: str) -> str:
    return (ROOT / path).read_text()


def _taylor(angle_deg: float) -> str:
    text = _shipped("studies/published/taylor_phi0.toml")
    return text[:text.index("[sweep]")].replace("angle_deg = 60.0", f"angle_deg = {angle_deg}")


# (gradient, phi (deg), c (kPa), gamma (kN/m3), ru): the six slopes of issue #45's table (c chosen
# for an FOS near 1.3) and Li & Lumb's (1987) 45 deg slope, dry and at ru = 0.2, on its 5 m foundation
C_PHI_SLOPES = {
    "phi10_2h1v": (2.0, 10.0, 20.0, 20.0, 0.0),
    "phi25_2h1v": (2.0, 25.0, 10.0, 20.0, 0.0),
    "phi30_1.5h1v": (1.5, 30.0, 10.0, 20.0, 0.0),
    "phi35_1h1v": (1.0, 35.0, 10.0, 20.0, 0.0),
    "phi40_1h1v": (1.0, 40.0, 5.0, 20.0, 0.0),
    "phi35_0.5h1v": (0.5, 35.0, 20.0, 20.0, 0.0),
    "li_lumb_dry": (1.0, 30.0, 18.0, 18.0, 0.0),
    "li_lumb_ru0.2": (1.0, 30.0, 18.0, 18.0, 0.2),
}


def c_phi_text(name: str) -> str:
    """A homogeneous c-phi slope 10 m high on a 5 m foundation (the slope form), of C_PHI_SLOPES[name]."""
    gradient, phi, cohesion, gamma, ru = C_PHI_SLOPES[name]
    soil = {"name": "soil", "model": "drucker_prager", "unit_weight_kn_m3": gamma, "youngs_modulus_mpa": 100.0,
            "poisson_ratio": 0.3, "cohesion_kpa": cohesion, "friction_deg": phi}
    water = {"water": {"ru": ru}} if ru > 0.0 else {}
    return study_text(name.replace(".", "_"), {"spacing_m": 1.0, "slope": slope_form(10.0, gradient, foundation_depth_m=5.0)},
                      [soil], [gravity_stage(20.0, 0.05), srf_stage(8.0, 0.02, fos_tolerance=0.005)], **water)


def c_phi_upper_bound(name: str) -> float:
    """The least log spiral of the slope (its ground as the slope form makes it)."""
    from verification.log_spiral import least_spiral

    gradient, phi, cohesion, gamma, ru = C_PHI_SLOPES[name]
    crest, run, foundation, height = 20.0, 10.0 * gradient, 5.0, 10.0
    ground = [(0.0, foundation + height), (crest, foundation + height), (crest + run, foundation),
              (crest + run + 20.0, foundation)]
    return least_spiral(ground, cohesion * 1e3, phi, gamma * 1e3, ru).fos


def cases(names: list[str]) -> dict[str, Case]:
    from verification.least_circle import slope_least_circle

    shipped = {
        "quickstart": lambda: Case(_shipped("studies/quickstart.toml"), 10.0, 1.368, "limit equilibrium", 1.3682),
        "reference_slope": lambda: Case(_shipped("studies/reference_slope.toml"), 10.0, 1.368, "limit equilibrium",
                                        1.3682),
        "griffiths_lane_ex4": lambda: Case(_shipped("studies/published/griffiths_lane_ex4.toml"), 10.0, 1.472,
                                           "least circle", 1.472),
        "acads_1a": lambda: Case(_shipped("studies/published/acads_1a.toml"), 10.0, 0.986, "Spencer", 0.985),
        "acads_1c": lambda: Case(_shipped("studies/published/acads_1c.toml"), 10.0, 1.375, "Spencer", None),
        "verruijt_slope": lambda: Case(_shipped("studies/published/verruijt_slope.toml"), 4.5, 1.534, "Bishop", 1.542),
    }
    for angle, n in ((53.0, 0.181), (60.0, 0.191), (75.0, 0.219), (90.0, 0.261)):
        shipped[f"taylor_{angle:g}"] = (lambda a=angle, n=n: Case(
            _taylor(a), 5.0, 20e3 / (n * 20e3 * 5.0), "Taylor's chart", slope_least_circle(5.0, a, 20e3, 20e3, 0.0).fos))
    for name in C_PHI_SLOPES:
        shipped[name] = lambda name=name: Case(c_phi_text(name), 10.0, math.nan, "least log spiral",
                                               c_phi_upper_bound(name))
    picked = {}
    for name in names:
        case = shipped[name]()
        if math.isnan(case.reference):
            case = Case(case.text, case.height_m, case.upper_bound, case.reference_name, case.upper_bound)
        picked[name] = case
    return picked


CASE_NAMES = (["quickstart", "reference_slope", "griffiths_lane_ex4", "acads_1a", "acads_1c", "verruijt_slope"]
              + [f"taylor_{a:g}" for a in (53.0, 60.0, 75.0, 90.0)] + list(C_PHI_SLOPES))


def _with_spacing(text: str, spacing_m: float) -> str:
    return re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)


def _fos(out: Path) -> float:
    with xr.open_dataset(out / "summary.nc") as ds:
        return float(ds["fos"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=CASE_NAMES, choices=CASE_NAMES)
    args = parser.parse_args(argv)
    print("| case | reference | upper bound | FOS as shipped (h) | controlled FOS +- U (95%) | levels | particles "
          "| error | holds | below UB | excess at H/10 | excess at H/20 | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for name, case in cases(args.cases).items():
            folder = Path(scratch) / name
            shipped_spacing = float(re.search(r"(?m)^spacing_m = (.*)$", case.text).group(1))
            shipped = _fos(run_study_command(case.text, folder / "shipped")[0])
            controlled_text = _with_spacing(case.text, case.height_m / 10.0) + "\n[refinement]\n"
            out, wall = run_study_command(controlled_text, folder / "controlled")
            with xr.open_dataset(out / "refinement.nc") as ds:
                f0, u = float(ds["fos_limit"]), float(ds["fos_uncertainty"])
                levels = ds["fos"].values
                spacings = ds["spacing"].values
                particles = int(ds["n_particles"].values.max())
                trusted = bool(ds.attrs["band_trusted"])
            excess = {n: levels[abs(spacings - case.height_m / n) < 1e-3 * case.height_m] for n in (10, 20)}
            ub = case.upper_bound
            holds = f0 - u <= case.reference <= f0 + u
            print(f"| {name} | {case.reference:.4f} ({case.reference_name}) | "
                  f"{'-' if ub is None else f'{ub:.4f}'} | {shipped:.4f} ({shipped_spacing:g} m) | "
                  f"{f0:.4f} +- {u:.4f} ({100 * u / f0:.2g}%{'' if trusted else ', not trusted'}) | {len(levels)} | "
                  f"{particles} | {100 * (f0 / case.reference - 1):+.2f}% | {'yes' if holds else 'no'} | "
                  f"{'-' if ub is None else ('yes' if f0 <= ub else 'NO')} | "
                  + " | ".join(f"{100 * (v[0] / f0 - 1):+.2f}%" if v.size else "-" for v in excess.values())
                  + f" | {wall:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
