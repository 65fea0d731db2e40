"""``model = "drucker_prager"``: Drucker-Prager matched to Mohr-Coulomb (the core's
``spfem_core.materials.drucker_prager``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import text
from workflows.materials.base import FrictionalStrength, MaterialBase

MOHR_COULOMB_MATCH = "mohr_coulomb_match"
"""The study's name for the core's default fit (the plane-strain match for the dilation)."""

DP_FIT_CHOICES = (MOHR_COULOMB_MATCH, "inner", "outer", "plane_strain_associated", "plane_strain_nonassociated")
"""The fits a study may name (the core's ``drucker_prager.DP_FITS`` and the default)."""


@dataclass(frozen=True, kw_only=True)
class DruckerPragerMaterial(FrictionalStrength, MaterialBase):
    """Drucker-Prager, perfectly plastic, plane strain; the fit sets its match to Mohr-Coulomb."""

    model: ClassVar[str] = "drucker_prager"
    dp_fit: str = text(
        "cone fitted to Mohr-Coulomb: `mohr_coulomb_match` picks the plane-strain fit that reproduces "
        "Mohr-Coulomb at collapse for the given dilation; `inner` is ESPFEM2D's",
        default=MOHR_COULOMB_MATCH, choices=DP_FIT_CHOICES,
    )

    def core_properties(self) -> dict:
        """c, phi, psi, sigma_t and the fit (``mohr_coulomb_match``: the core's default, "")."""
        return self.frictional_properties() | {"dp_fit": "" if self.dp_fit == MOHR_COULOMB_MATCH else self.dp_fit}
