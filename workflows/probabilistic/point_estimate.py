"""The point estimate method (Rosenblueth 1975): the FOS's mean and standard deviation from 2^n points.

Each of the n random variables takes its mean plus or minus its standard deviation,
``x_i = mu_i + s_i sigma_i`` with ``s_i = +-1``; the 2^n points carry the weights (Rosenblueth's, with
the variables' own correlation ``rho_ij``)

    P_s = (1 + sum_{i<j} s_i s_j rho_ij) / 2^n,

and the FOS's moments are ``E[F] = sum P_s F_s``, ``E[F^2] = sum P_s F_s^2``.  From them the reliability
indices of a normal and of a lognormal FOS against the factor ``f`` (Slide2's, with ``f = 1``):

    beta_N = (mu_F - f) / sigma_F,    beta_LN = ln(mu_F / (f sqrt(1 + V_F^2))) / sqrt(ln(1 + V_F^2)).

It is a screen: two moments from 2^n FOS searches, exact for a FOS linear in the variables, and
nothing of the tail beyond what the assumed law of the FOS puts there.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def signs(n: int) -> np.ndarray:
    """(2^n, n) the signs s of every point, the first variable's changing slowest."""
    return np.array(list(itertools.product((-1.0, 1.0), repeat=n))).reshape(-1, n)


def weights(correlation: np.ndarray) -> np.ndarray:
    """(2^n,) Rosenblueth's weights of the points of :func:`signs` (module doc); ValueError where one is
    negative (a correlation the 2^n points cannot carry)."""
    correlation = np.asarray(correlation, float)
    n = correlation.shape[0]
    s = signs(n)
    upper = np.triu(correlation, 1)
    p = (1.0 + np.einsum("ki,ij,kj->k", s, upper, s)) / 2.0**n
    if (p < 0.0).any():
        raise ValueError("the correlation gives a point a negative weight in Rosenblueth's method")
    return p


def points(means: np.ndarray, stds: np.ndarray) -> np.ndarray:
    """(2^n, n): mu_i + s_i sigma_i at every point of :func:`signs`."""
    means, stds = np.asarray(means, float), np.asarray(stds, float)
    return means + signs(means.size) * stds


def moments(fos: np.ndarray, point_weights: np.ndarray) -> tuple[float, float]:
    """(mu_F, sigma_F) of the FOS at the points with their weights."""
    fos = np.asarray(fos, float)
    mean = float(point_weights @ fos)
    return mean, math.sqrt(max(float(point_weights @ (fos - mean) ** 2), 0.0))


def reliability_indices(mean: float, std: float, factor: float) -> tuple[float, float]:
    """(beta_N, beta_LN) of a FOS of ``mean`` and ``std`` against ``factor`` (module doc)."""
    v2 = (std / mean) ** 2
    return (mean - factor) / std, math.log(mean / (factor * math.sqrt(1.0 + v2))) / math.sqrt(math.log1p(v2))
