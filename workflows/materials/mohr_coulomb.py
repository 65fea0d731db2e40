"""``model = "mohr_coulomb"``: Mohr-Coulomb, perfectly plastic or softening (the core's
``spfem_core.materials.mohr_coulomb``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import StudyError, number, text
from workflows.materials.base import FrictionalStrength, MaterialBase


@dataclass(frozen=True, kw_only=True)
class MohrCoulombMaterial(FrictionalStrength, MaterialBase):
    """Mohr-Coulomb, plane strain (return map in principal stresses), perfectly plastic or softening from
    peak (cohesion_pa, friction_deg) to residual strength with the equivalent plastic strain."""

    model: ClassVar[str] = "mohr_coulomb"
    softening: str = text(
        "strain softening from peak to residual strength: `none`, `linear` (from softening_start_strain to "
        "softening_end_strain) or `exponential` (1 - exp(-3 (eps - start) / (end - start)) of the drop)",
        default="none", choices=("none", "linear", "exponential"),
    )
    residual_cohesion_pa: float | None = number("Pa", "*softening:* residual cohesion c_r; default cohesion_pa",
                                                default=None, ge=0.0)
    residual_friction_deg: float | None = number("degree", "*softening:* residual friction angle phi_r; default "
                                                 "friction_deg", default=None, ge=0.0, lt=90.0)
    softening_start_strain: float = number("1", "*softening:* equivalent plastic strain where the strength starts "
                                           "to fall", default=0.0, ge=0.0)
    softening_end_strain: float | None = number("1", "*softening:* equivalent plastic strain where it reaches the "
                                                "residual (exponential: 95% of the drop)", default=None, gt=0.0)

    def check(self):
        super().check()
        given = [name for name in ("residual_cohesion_pa", "residual_friction_deg", "softening_end_strain")
                 if getattr(self, name) is not None]
        if self.softening == "none":
            if given:
                raise StudyError(given[0], "applies with softening = linear or exponential only")
            return
        if self.softening_end_strain is None:
            raise StudyError("softening_end_strain", "required with softening")
        if self.softening_end_strain <= self.softening_start_strain:
            raise StudyError("softening_end_strain", f"must be > softening_start_strain = "
                             f"{self.softening_start_strain:g}, got {self.softening_end_strain:g}")
        if self.residual_cohesion_or_peak > self.cohesion_pa:
            raise StudyError("residual_cohesion_pa", f"must be <= cohesion_pa = {self.cohesion_pa:g}")
        if self.residual_friction_or_peak > self.friction_deg:
            raise StudyError("residual_friction_deg", f"must be <= friction_deg = {self.friction_deg:g}")
        if self.residual_cohesion_or_peak == 0.0 and self.residual_friction_or_peak == 0.0:
            raise StudyError("residual_cohesion_pa", "a residual strength of c = 0 and phi = 0 is no strength")

    @property
    def residual_cohesion_or_peak(self) -> float:
        return self.cohesion_pa if self.residual_cohesion_pa is None else self.residual_cohesion_pa

    @property
    def residual_friction_or_peak(self) -> float:
        return self.friction_deg if self.residual_friction_deg is None else self.residual_friction_deg

    def core_properties(self) -> dict:
        """c, phi, psi, sigma_t and, with softening, the law, the residual strength and its strains."""
        properties = self.frictional_properties()
        if self.softening != "none":
            properties |= {"softening_law": self.softening, "residual_cohesion_pa": self.residual_cohesion_or_peak,
                           "residual_friction_deg": self.residual_friction_or_peak,
                           "softening_start_strain": self.softening_start_strain,
                           "softening_end_strain": self.softening_end_strain}
        return properties
