"""Variants of ``studies/probabilistic_undrained.toml`` for the probabilistic verifications: the
deterministic study, one lognormal cu per realisation, or a cu field of a given COV and theta."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "probabilistic_undrained.toml"
SINGLE_VARIABLE = ('[[probabilistic.variables]]\npath = "materials.clay.cohesion_pa"\ndistribution = "lognormal"\n'
                   'cov = {cov:g}\n')


def shipped_text(spacing_m: float | None = None) -> str:
    """The shipped study, at ``spacing_m`` if given."""
    text = STUDY.read_text()
    if spacing_m is not None:
        text = re.sub(r"(?m)^spacing_m = .*$", f"spacing_m = {spacing_m:g}", text, count=1)
    return text


def _without_random_field(text: str) -> str:
    return text[: text.index("[random_field]")]


def deterministic_text(text: str, tolerance: float) -> str:
    """The study without ``[probabilistic]`` and ``[random_field]``, its search to ``tolerance``."""
    text = text[: text.index("[probabilistic]")]
    return re.sub(r"(?m)^(srf_step = .*)$", rf"\1\nfos_tolerance = {tolerance:g}", text, count=1)


def _realisations(text: str, count: int) -> str:
    return re.sub(r"(?m)^realisations = .*$", f"realisations = {count}", text, count=1)


def single_variable_text(text: str, cov: float, realisations: int) -> str:
    """One lognormal cu per realisation (no spatial variation): the limit theta -> infinity."""
    return _realisations(_without_random_field(text), realisations) + "\n" + SINGLE_VARIABLE.format(cov=cov)


def field_text(text: str, cov: float, theta_m: float, realisations: int) -> str:
    """The shipped cu field at ``cov`` and the isotropic scale of fluctuation ``theta_m``."""
    text = re.sub(r"(?m)^cov = .*$", f"cov = {cov:g}", text, count=1)
    text = re.sub(r"(?m)^theta_x_m = .*$", f"theta_x_m = {theta_m:g}", text, count=1)
    return _realisations(text, realisations)


def add_common_arguments(parser) -> None:
    """--spacing, --fos-tolerance and --workers of the probabilistic verifications."""
    parser.add_argument("--spacing", type=float, default=None, help="particle spacing (m), default the study's")
    parser.add_argument("--fos-tolerance", type=float, default=0.002)
    parser.add_argument("--workers", type=int, default=2)


def deterministic_fos(text: str, tolerance: float, options, out_dir: Path) -> float:
    """F_det: the FOS of the study without its randomness, searched to ``tolerance``, printed with
    its bracket and cu_crit = mean cu / F_det."""
    from workflows.study import parse_study
    from workflows.study_types import run_study

    study = parse_study(text)
    outcome = run_study(parse_study(deterministic_text(text, tolerance)), out_dir, options)
    mean_cu = study.materials[0].cohesion_pa
    print(f"F_det = {outcome.fos:.4f} [{outcome.fos_low:.4f}, {outcome.fos_high:.4f}] at h = "
          f"{study.geometry.spacing_m:g} m; cu_crit = {mean_cu / outcome.fos / 1e3:.3f} kPa\n", flush=True)
    return outcome.fos
