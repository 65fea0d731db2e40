"""Probabilistic studies: the probability of failure over uncertain soil.

- ``sampling``: random variables (normal, lognormal, uniform, truncated normal) tied by a
  correlation matrix through a Gaussian copula; Monte Carlo and Latin hypercube designs;
- ``reliability``: the probability of failure with its confidence interval, and the
  reliability index;
- ``field_mechanisms``: a realisation's FOS estimated by limit equilibrium through its random fields
  (``workflows.random_field``) on every circle of the mean soil: the window of its search;
- ``table`` (``[probabilistic]``), ``study_type`` (a case per realisation, run as a sweep's),
  ``sweep`` (a probabilistic study per case of a ``[sweep]``), ``results`` (``probabilistic.nc``)
  and ``figures``.
"""
