"""Probabilistic studies: the probability of failure over uncertain soil.

- ``random_field``: stationary Gaussian fields by circulant embedding, cell-averaged at the
  particles (Markov and Gaussian correlation, anisotropic scales of fluctuation);
- ``sampling``: random variables (normal, lognormal, uniform, truncated normal) tied by a
  correlation matrix through a Gaussian copula; Monte Carlo and Latin hypercube designs;
- ``reliability``: the probability of failure with its confidence interval, and the
  reliability index;
- ``table`` (``[probabilistic]``), ``study_type`` (a case per realisation, run as a sweep's) and
  ``results`` (``probabilistic.nc``).

Random fields are not yet declared in a study file.
"""
