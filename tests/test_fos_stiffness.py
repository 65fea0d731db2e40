"""The factor of safety does not depend on the soil's stiffness: the strength-reduction runs are
made at moduli scaled so that the slope's elastic response stays small against the failure
displacement (``StrengthReductionStage.stiffness_factor``, docs/method.md section 9)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import xarray as xr

from spfem_core.materials.table import MaterialTable
from workflows.cases import RunOptions
from workflows.scene import build_material_table
from workflows.stages.strength_reduction import ELASTIC_RESPONSE
from workflows.study import StudyError, parse_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]
QUICKSTART = (REPO / "studies" / "quickstart.toml").read_text()


def with_modulus(text: str, youngs_modulus_pa: float) -> str:
    return text.replace("youngs_modulus_pa = 100e6", f"youngs_modulus_pa = {youngs_modulus_pa:g}")


def test_the_factor_brings_every_stiffness_to_the_same_elastic_response():
    """s = rho g H / (2 G) / ELASTIC_RESPONSE: the scaled shear modulus of the quickstart is the same
    from 10 MPa to 1 GPa."""
    scaled = []
    for modulus in (10e6, 20e6, 100e6, 1e9):
        study = parse_study(with_modulus(QUICKSTART, modulus))
        shear = modulus / (2.0 * 1.3)
        response = 2000.0 * 10.0 * study.slope_height_m / (2.0 * shear)
        factor = study.strength_reduction.stiffness_factor(build_material_table(study), study)
        assert factor == pytest.approx(response / ELASTIC_RESPONSE, rel=1e-12)
        scaled.append(factor * shear)
    assert scaled == pytest.approx([scaled[0]] * 4, rel=1e-12)


def test_no_scaling_when_switched_off_or_with_a_softening_material():
    study = parse_study(with_modulus(QUICKSTART, 20e6).replace("early_stop", "early_stop")
                        .replace("fos_tolerance = 0.01", "fos_tolerance = 0.01\nscale_stiffness = false"))
    assert study.strength_reduction.stiffness_factor(build_material_table(study), study) == 1.0
    soft = parse_study(with_modulus(QUICKSTART, 20e6))
    softening = MaterialTable.single("soil", "mohr_coulomb", 2000.0, 20e6, 0.3, cohesion_pa=10e3, friction_deg=20.0,
                                     softening_law="linear", residual_cohesion_pa=2e3,
                                     softening_end_strain=0.1)
    assert soft.strength_reduction.stiffness_factor(softening, soft) == 1.0


def test_scaled_moduli_keep_poisson_and_everything_else():
    table = MaterialTable.single("soil", "drucker_prager", 2000.0, 20e6, 0.3, cohesion_pa=10e3, friction_deg=20.0)
    scaled = table.with_moduli_scaled(4.0)
    assert scaled.youngs_modulus_pa[0] == 80e6 and scaled.poisson_ratio[0] == 0.3
    assert scaled.shear_modulus_pa[0] == pytest.approx(4.0 * table.shear_modulus_pa[0])
    assert (scaled.kernel_constants() == table.kernel_constants()).all()


def test_a_loose_convergence_tolerance_is_refused():
    """1e-3 ends runs before the slope has responded (+1.2% on the quickstart at h = 0.5 m)."""
    text = QUICKSTART.replace("fos_tolerance = 0.01", "fos_tolerance = 0.01\ntolerance = 1e-3")
    with pytest.raises(StudyError) as error:
        parse_study(text)
    assert error.value.field == "stages[1].tolerance" and "<= 0.0001" in str(error.value)


def test_the_fos_is_the_same_from_10_mpa_to_1_gpa_and_soft_soil_without_scaling_fails_early(quickstart_run,
                                                                                            tmp_path):
    """The quickstart (h = 1 m) at E = 10 MPa and 1 GPa gives the FOS of 100 MPa within the search
    tolerance; at 10 MPa with the declared moduli the contained displacement passes the failure
    displacement long before the FOS (what the scaling is for)."""
    _, _, reference = quickstart_run
    tolerance = parse_study(QUICKSTART).strength_reduction.fos_tolerance
    for modulus in (10e6, 1e9):
        outcome = run_study(parse_study(with_modulus(QUICKSTART, modulus)), tmp_path / f"{modulus:g}",
                            RunOptions(workers=2))
        assert abs(outcome.fos - reference.fos) <= tolerance, (modulus, outcome.fos, reference.fos)
        assert outcome.criteria_agree
        factor = xr.load_dataset(outcome.summary_path).attrs["srf_stiffness_factor"]
        assert factor == pytest.approx(100e6 / modulus * 0.0026 / ELASTIC_RESPONSE, rel=0.01)
    declared = with_modulus(QUICKSTART, 10e6).replace("fos_tolerance = 0.01", "fos_tolerance = 0.01\nscale_stiffness = false")
    unscaled = run_study(parse_study(declared), tmp_path / "declared", RunOptions(workers=2))
    assert not math.isfinite(unscaled.fos) or unscaled.fos < reference.fos - 0.03
