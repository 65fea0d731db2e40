"""What every material of a study file has, and how a material becomes a row of the core's table.

A material model of the study file (``elastic``, ``drucker_prager``, ``mohr_coulomb``) is a
module of this package: its declaration (a table with ``model = "<name>"``, built on
:class:`MaterialBase`) and :meth:`MaterialBase.core_properties`, its translation to the
properties of the core's model of the same name (``spfem_core.materials``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.fields import Record, StudyError, name_field, number, polygon, polyline, specs


@dataclass(frozen=True, kw_only=True)
class MaterialBase(Record):
    """Fields shared by every material model."""

    model: ClassVar[str]
    name: str = name_field("name of the material")
    density_kg_m3: float = number("kg m-3", "mass density rho", ge=1.0)
    youngs_modulus_pa: float = number("Pa", "Young's modulus E", ge=1.0)
    poisson_ratio: float = number("1", "Poisson's ratio nu", ge=0.0, lt=0.5)
    region_m: tuple | None = polygon(
        "m", "polygon of the particles that get this material; default: the whole domain; "
        "later materials override earlier ones", default=None
    )
    saturated_density_kg_m3: float | None = number(
        "kg m-3", "mass density at or below the piezometric line; default density_kg_m3 (one total unit "
        "weight above and below)", default=None, ge=1.0,
    )
    phreatic_line_m: tuple | None = polyline(
        "m", "this material's own piezometric line [[x, y], ...] (a perched water table), instead of [water]'s; "
        "x increasing, spanning the domain", default=None,
    )
    permeability_m_s: float | None = number(
        "m s-1", "*with [seepage]:* saturated hydraulic conductivity k (along permeability_angle_deg); required "
        "there", default=None, gt=0.0,
    )
    permeability_ratio: float = number("1", "*with [seepage]:* k across / k along the principal direction "
                                       "(anisotropy; layered ground: below 1)", default=1.0, gt=0.0)
    permeability_angle_deg: float = number("degree", "*with [seepage]:* direction of the larger conductivity from "
                                           "the horizontal, anticlockwise", default=0.0, ge=-90.0, le=90.0)

    @property
    def plastic(self) -> bool:
        """Whether the material has a strength (every model but ``elastic``)."""
        return True

    def core_properties(self) -> dict:
        """The properties of the core's model ``self.model`` (``spfem_core.materials``), by their
        core names; a model with properties of its own overrides this."""
        return {}

    def core_row(self) -> dict:
        """This material as a row of ``spfem_core.materials.table.MaterialTable.from_rows``."""
        return {"name": self.name, "model": self.model, "density_kg_m3": self.density_kg_m3,
                "youngs_modulus_pa": self.youngs_modulus_pa, "poisson_ratio": self.poisson_ratio,
                **self.core_properties()}

    @classmethod
    def strength_fields(cls) -> tuple[str, ...]:
        """The model's own fields: what a linear elastic stage does not read (``fos.keys``)."""
        shared = specs(MaterialBase)
        return tuple(name for name in specs(cls) if name not in shared)


@dataclass(frozen=True, kw_only=True)
class FrictionalStrength(Record):
    """Shear strength (c, phi, psi) of a perfectly plastic frictional material, with a tension cut-off."""

    cohesion_pa: float = number("Pa", "cohesion c", ge=0.0)
    friction_deg: float = number("degree", "friction angle phi", ge=0.0, lt=90.0)
    dilation_deg: float = number("degree", "dilation angle psi (<= phi); 0: no plastic volume change", default=0.0,
                                 ge=0.0)
    tensile_strength_pa: float | None = number(
        "Pa", "tension cut-off sigma_t: Mohr-Coulomb caps the largest principal stress, Drucker-Prager the mean "
        "stress, at sigma_t (reduced with c in strength reduction); default: none (the yield surface's own apex, "
        "c cot phi)", default=None, ge=0.0,
    )

    def check(self):
        if self.dilation_deg > self.friction_deg:
            raise StudyError("dilation_deg",
                             f"must be <= friction_deg = {self.friction_deg:g}, got {self.dilation_deg:g}")
        if self.cohesion_pa == 0.0 and self.friction_deg == 0.0:
            raise StudyError("cohesion_pa", "a material with c = 0 and phi = 0 has no strength")

    def frictional_properties(self) -> dict:
        """c, phi, psi and the tensile strength as the core's frictional models read them."""
        properties = {"cohesion_pa": self.cohesion_pa, "friction_deg": self.friction_deg,
                      "dilation_deg": self.dilation_deg}
        if self.tensile_strength_pa is not None:
            properties["tensile_strength_pa"] = self.tensile_strength_pa
        return properties
