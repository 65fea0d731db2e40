"""The material models of a study file, one module each, and their registry.

Each module declares its ``[[materials]]`` table (``model = "<name>"``, built on
``base.MaterialBase``) and translates it to the properties of the core's model of the same name
(``core_properties``, read by ``spfem_core.materials``).  :data:`MATERIAL_MODELS` is the one
list of them; adding a model: docs/architecture.md.
"""

from __future__ import annotations

from workflows.materials.base import MaterialBase
from workflows.materials.drucker_prager import DruckerPragerMaterial
from workflows.materials.elastic import ElasticMaterial
from workflows.materials.mohr_coulomb import MohrCoulombMaterial
from workflows.materials.tresca import TrescaMaterial

MATERIAL_MODELS: dict[str, type[MaterialBase]] = {
    model.model: model for model in (ElasticMaterial, DruckerPragerMaterial, MohrCoulombMaterial, TrescaMaterial)
}
"""Every material model of a study file, by its ``model`` name."""

__all__ = ["MATERIAL_MODELS", "MaterialBase", "DruckerPragerMaterial", "ElasticMaterial", "MohrCoulombMaterial",
           "TrescaMaterial"]
