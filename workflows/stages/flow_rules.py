"""The flow rules of a strength reduction (the stage's ``flow_rule``): the dilation angle of each
material at F, with the friction reduced to tan(phi_F) = tan(phi) / F.

- ``associated``: psi_F = phi_F (the plastic flow normal to the reduced yield surface);
- ``as_declared``: psi_F = min(psi, phi_F), psi each material's ``dilation_deg``.

The core applies it (``MaterialTable.with_strength_reduction``, ``associated``); a rule here is the
name the study file gives, its description for the reference, and which of the two it is.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FlowRule:
    """One flow rule of the module doc."""

    name: str
    description: str  # the reference's words
    associated: bool  # psi_F = phi_F; else psi_F = min(psi, phi_F)

    def reduced(self, table, srf: float):
        """The core's material ``table`` with its strength divided by ``srf`` under this rule."""
        return table.with_strength_reduction(srf, associated=self.associated)


FLOW_RULES = {rule.name: rule for rule in (
    FlowRule("associated", "the dilation follows the reduced friction, psi_F = phi_F, the flow rule under which "
             "limit equilibrium and limit analysis give the FOS", associated=True),
    FlowRule("as_declared", "psi_F = min(psi, phi_F) with each material's dilation_deg (psi = 0 gives a lower FOS, "
             "about 2% at phi = 20 deg)", associated=False),
)}
"""Every flow rule, by the name the study file gives."""
