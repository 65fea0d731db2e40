"""``model = "tresca"``: an undrained clay of undrained shear strength c_u, Tresca (the core's
``spfem_core.materials.tresca``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import number
from workflows.materials.base import MaterialBase


@dataclass(frozen=True, kw_only=True)
class TrescaMaterial(MaterialBase):
    """Tresca, perfectly plastic, plane strain: undrained shear strength c_u (total stress, phi = 0)."""

    model: ClassVar[str] = "tresca"
    undrained_shear_strength_pa: float = number(
        "Pa", "undrained shear strength c_u: the largest shear stress, (s1 - s3) / 2 <= c_u", gt=0.0,
    )
    tensile_strength_pa: float | None = number(
        "Pa", "tension cut-off sigma_t on the largest principal stress (reduced with c_u in strength reduction); "
        "default: none", default=None, ge=0.0,
    )

    def core_properties(self) -> dict:
        """c_u and, when given, the tensile strength."""
        properties = {"undrained_shear_strength_pa": self.undrained_shear_strength_pa}
        if self.tensile_strength_pa is not None:
            properties["tensile_strength_pa"] = self.tensile_strength_pa
        return properties
