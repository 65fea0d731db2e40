"""Probabilistic studies (issue [3/7], in progress): the building blocks so far.

- ``random_field``: stationary Gaussian fields by circulant embedding, cell-averaged at the
  particles (Markov and Gaussian correlation, anisotropic scales of fluctuation);
- ``sampling``: random variables (normal, lognormal, uniform, truncated normal) tied by a
  correlation matrix through a Gaussian copula; Monte Carlo and Latin hypercube designs;
- ``reliability``: the probability of failure with its confidence interval, and the
  reliability index.

No study type uses them yet: a study file cannot declare random variables or fields.
"""
