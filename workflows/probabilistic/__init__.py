"""Probabilistic studies: the probability of failure over uncertain soil.

- ``random_field``: stationary Gaussian fields by circulant embedding, cell-averaged at the
  particles (Markov and Gaussian correlation, anisotropic scales of fluctuation);
- ``sampling``: random variables (normal, lognormal, uniform, truncated normal) tied by a
  correlation matrix through a Gaussian copula; Monte Carlo and Latin hypercube designs;
- ``reliability``: the probability of failure with its confidence interval, and the
  reliability index;
- ``spatial`` (``[random_field]``): properties of materials as random fields, their values at the
  particles;
- ``table`` (``[probabilistic]``), ``study_type`` (a case per realisation, run as a sweep's),
  ``sweep`` (a probabilistic study per case of a ``[sweep]``), ``results`` (``probabilistic.nc``)
  and ``figures``.
"""
