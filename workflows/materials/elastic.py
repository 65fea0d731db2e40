"""``model = "elastic"``: linear elastic, plane strain (the core's ``spfem_core.materials.elastic``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from workflows.materials.base import MaterialBase


@dataclass(frozen=True, kw_only=True)
class ElasticMaterial(MaterialBase):
    """Linear elastic, plane strain."""

    model: ClassVar[str] = "elastic"

    @property
    def plastic(self) -> bool:
        return False
