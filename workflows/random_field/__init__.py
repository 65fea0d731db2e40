"""Spatially variable soil (``[random_field]``): a material's properties as random fields.

- ``table`` (``[random_field]``): the declaration, its checks, and the point laws they use
  (``spread_problem``, ``order_broken_probability``; the point laws are ``workflows.distributions``);
- ``embedding``: stationary Gaussian fields by circulant embedding, averaged over each particle's
  cell;
- ``values``: the fields of a study drawn, and their values at its particles, for the scene
  (``workflows.scene``) and the steady flow (``workflows.seepage.flow``).

A probabilistic study (``workflows.probabilistic``) draws a realisation of them per case.
"""
