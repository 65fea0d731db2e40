"""Material models, one module each, and the one place that knows them all (this one).

A model module (``elastic``, ``drucker_prager``, ``mohr_coulomb``, ``tresca``) holds:

- ``NAME`` and ``CODE`` (its position in :data:`MODELS`, the value of ``MaterialTable.model``);
- ``PROPERTIES``: the properties it reads (``properties.Property``: name with its unit, default, range);
- ``check(properties)``: what its properties must satisfy together, or None;
- ``CONSTANTS`` and ``constants(properties, n_rows)``: the named columns the kernels read, made
  from the properties of its rows (``MaterialTable.kernel_constants``);
- ``reduced(properties, srf, associated)``: what strength reduction by F does to its properties;
- ``slip_strength(properties, n_rows)``: (c, tan phi) of a support the soil slides along, the
  Mohr-Coulomb envelope tau = c + sigma_n tan(phi) of its (reduced) strength (c = inf: it cannot slide);
- its return map ``<NAME>_update(stress, k_row, dxx, dyy, dxy, lame_lambda, shear_modulus, *constants)``,
  a compiled kernel of one particle's stress taking its leading constants as numbers in the
  order of ``CONSTANTS``, returning (equivalent plastic strain increment, dissipation in J/m^3).

:data:`MODELS` lists them; ``constitutive.update_stress_range`` is the one dispatch on the code
(it reads each model's named columns of the particle's row and calls its return map, then the
tension cut-off: written there, not in an inlined function of each model, which made the plastic
update 25-50% slower, docs/benchmarks.md); a code without its branch there stops the update
with a ValueError (``tests/test_material_dispatch.py`` runs a row of every model of
:data:`MODELS` through it against its own return map).  ``table.MaterialTable``
holds the rows of any mix of models, one row per material or per particle.  Shared pieces:
``return_map`` (elastic trial, plastic measures, principal stresses), ``frictional`` (c, phi,
psi and their reduction) and ``tension_cutoff``.  Adding a model: its module here, a line in
:data:`MODELS`, a branch in ``constitutive.update_stress_range`` (docs/architecture.md).
"""

from __future__ import annotations

from spfem_core.materials import drucker_prager, elastic, mohr_coulomb, tresca

MODELS = (elastic, drucker_prager, mohr_coulomb, tresca)
"""Every material model, in the order of their codes."""

MODEL_CODES = {model.NAME: model.CODE for model in MODELS}
"""Code of every model by its name."""

assert all(model.CODE == code for code, model in enumerate(MODELS)), "a model's CODE is its position in MODELS"

