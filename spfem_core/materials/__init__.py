"""Material models, one module each, and the one place that knows them all (this one).

A model module (``elastic``, ``drucker_prager``, ``mohr_coulomb``) holds:

- ``NAME`` and ``CODE`` (its position in :data:`MODELS`, the value of ``MaterialTable.model``);
- ``PROPERTIES``: the properties it reads (``properties.Property``: name with its unit, default, range);
- ``check(properties)``: what its properties must satisfy together, or None;
- ``CONSTANTS`` and ``constants(properties, n_rows)``: the named columns the kernels read, made
  from the properties of its rows (``MaterialTable.kernel_constants``);
- ``reduced(properties, srf, associated)``: what strength reduction by F does to its properties;
- ``update(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, params, row, plastic_strain)``:
  its compiled stress update of one particle, reading its own columns of row ``row``, returning
  (equivalent plastic strain increment, dissipation in J/m^3).

:data:`MODELS` lists them and :func:`plastic_update` dispatches on the code; ``table.MaterialTable``
holds the rows of any mix of models, one row per material or per particle.  Shared pieces:
``return_map`` (elastic trial, plastic measures, principal stresses), ``frictional`` (c, phi,
psi and their reduction) and ``tension_cutoff``.  Adding a model: its module here, a line in
:data:`MODELS`, a branch in :func:`plastic_update` (docs/architecture.md).
"""

from __future__ import annotations

from spfem_core.jit import inline_kernel
from spfem_core.materials import drucker_prager, elastic, mohr_coulomb, tresca

MODELS = (elastic, drucker_prager, mohr_coulomb, tresca)
"""Every material model, in the order of their codes."""

MODEL_CODES = {model.NAME: model.CODE for model in MODELS}
"""Code of every model by its name."""

assert all(model.CODE == code for code, model in enumerate(MODELS)), "a model's CODE is its position in MODELS"


@inline_kernel
def plastic_update(model, stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, params, row, plastic_strain):
    """The stress update of particle k by the plastic model of code ``model`` (every model but
    ``elastic``, which the caller applies itself); (equivalent plastic strain increment,
    dissipation in J/m^3)."""
    if model == drucker_prager.CODE:
        return drucker_prager.update(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, params, row,
                                     plastic_strain)
    if model == mohr_coulomb.CODE:
        return mohr_coulomb.update(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, params, row,
                                   plastic_strain)
    if model == tresca.CODE:
        return tresca.update(stress, k, dxx, dyy, dxy, lame_lambda, shear_modulus, params, row, plastic_strain)
    return 0.0, 0.0  # no other code: MaterialTable admits the codes of MODELS only
