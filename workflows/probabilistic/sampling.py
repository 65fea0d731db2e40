"""Random variables and their samples: Monte Carlo and Latin hypercube, with correlation.

A variable is a marginal distribution (:class:`Marginal`: one of ``workflows.distributions``, normal,
lognormal, uniform or a normal truncated to bounds, by mean and standard deviation); variables are tied by the
correlation matrix ``R`` of the variables themselves.  Samples are drawn through a Gaussian
copula (the Nataf model): standard normals ``z`` with correlation ``R_z``, then
``x_j = F_j^-1(Phi(z_j))``.  ``R_z`` is found pair by pair so that the variables' own
correlation is ``R`` (:func:`normal_correlation`; a distribution's closed form where it has one, e.g. for two lognormals
``rho_z = ln(1 + rho V_1 V_2) / (sigma_ln1 sigma_ln2)``, else by quadrature and a root).

- **Monte Carlo**: realisation ``i`` draws its normals from the stream ``SeedSequence([seed,
  i])``, so it is the same whatever the number of realisations, of workers or the order they
  run in, and a study extended from 200 to 1,000 realisations keeps its first 200.
- **Latin hypercube**: each variable's ``N`` values fall one in each of ``N`` equal-probability
  strata, and Iman & Conover's (1982) rank reordering gives them the correlation ``R_z`` without
  moving any value out of its stratum.  A hypercube is drawn for its count: extending it is a
  new design (its realisations are not those of a smaller one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from workflows.distributions import Distribution

HERMITE_POINTS = 40
"""Gauss-Hermite points per axis of the quadrature of E[x_1 x_2] (:func:`normal_correlation`)."""


@dataclass(frozen=True)
class Marginal:
    """One variable's distribution (``workflows.distributions``): ``mean`` and ``std`` (of the variable
    itself); ``low``, ``high`` the bounds of a truncated normal (of the untruncated normal's mean and
    std) or of a uniform (whose mean and std then follow from them)."""

    distribution: Distribution
    mean: float
    std: float
    low: float = -math.inf
    high: float = math.inf

    def frozen(self):
        """The scipy.stats distribution."""
        return self.distribution.frozen(self)

    def from_normal(self, z: np.ndarray) -> np.ndarray:
        """x = F^-1(Phi(z)) (for a lognormal, exp(mu_ln + sigma_ln z) exactly)."""
        return self.distribution.from_normal(self, z)

    def standardised_from_normal(self, z: np.ndarray) -> np.ndarray:
        """(x - E[x]) / std(x) of x = F^-1(Phi(z)), computed without subtracting nearly equal numbers: a
        spread far below the mean (a lognormal of COV 1e-12) leaves x - E[x] as rounding noise and its
        std as 0 (each distribution's own formula, ``Distribution.standardised_from_normal``)."""
        return self.distribution.standardised_from_normal(self, np.asarray(z, dtype=float))


def normal_correlation(a: Marginal, b: Marginal, rho: float) -> float:
    """rho_z of the copula's normals that gives ``a`` and ``b`` the correlation ``rho`` (module
    doc); ValueError where no rho_z in (-1, 1) reaches it."""
    if rho == 0.0:
        return rho
    closed = a.distribution.copula_correlation(a, b, rho)
    if closed is not None:
        return closed
    nodes, weights = np.polynomial.hermite_e.hermegauss(HERMITE_POINTS)
    weights = weights / weights.sum()
    u, v = np.meshgrid(nodes, nodes, indexing="ij")
    w = np.outer(weights, weights)
    standard_a = a.standardised_from_normal(u)

    def achieved(rho_z: float) -> float:
        z2 = rho_z * u + math.sqrt(1.0 - rho_z * rho_z) * v
        return float((w * standard_a * b.standardised_from_normal(z2)).sum()) - rho

    low, high = achieved(-0.9999), achieved(0.9999)
    if low > 0.0 or high < 0.0:
        raise ValueError(f"a correlation of {rho:g} is out of reach of a {a.distribution.name} and a "
                         f"{b.distribution.name} "
                         f"variable (from {low + rho:.3g} to {high + rho:.3g})")
    from scipy import optimize  # scipy.optimize: only where it is used

    return float(optimize.brentq(achieved, -0.9999, 0.9999, xtol=1e-10))


class Sampler:
    """Realisations of correlated variables (module doc)."""

    def __init__(self, marginals: list[Marginal], correlation: np.ndarray | None = None):
        self.marginals = list(marginals)
        n = len(self.marginals)
        target = np.eye(n) if correlation is None else np.asarray(correlation, float)
        if target.shape != (n, n) or not np.allclose(target, target.T) or not np.allclose(np.diag(target), 1.0):
            raise ValueError(f"the correlation matrix must be symmetric {n} x {n} with ones on its diagonal")
        self.normal = np.eye(n)
        for i in range(n):
            for j in range(i + 1, n):
                self.normal[i, j] = self.normal[j, i] = normal_correlation(self.marginals[i], self.marginals[j],
                                                                           float(target[i, j]))
        try:
            self.cholesky = np.linalg.cholesky(self.normal)
        except np.linalg.LinAlgError:
            raise ValueError("the correlation matrix is not positive definite (for these distributions)") from None

    def monte_carlo(self, seed: int, indices) -> np.ndarray:
        """(len(indices), n) values of the realisations ``indices``, each from its own stream."""
        z = np.array([np.random.default_rng(np.random.SeedSequence([seed, int(i)])).standard_normal(len(self.marginals))
                      for i in indices]).reshape(-1, len(self.marginals))
        return self._values(z @ self.cholesky.T)

    def latin_hypercube(self, seed: int, count: int) -> np.ndarray:
        """(count, n) values: a stratified design with the target correlation (Iman & Conover)."""
        from scipy import stats  # scipy.stats (0.5 s): only where it is used

        n = len(self.marginals)
        design = stats.qmc.LatinHypercube(d=n, seed=np.random.default_rng(np.random.SeedSequence([seed, count])))
        z = stats.norm.ppf(design.random(count))
        if n > 1 and count > n:
            z = _iman_conover(z, self.normal, np.random.default_rng(np.random.SeedSequence([seed, count, 1])))
        return self._values(z)

    def _values(self, z: np.ndarray) -> np.ndarray:
        return np.column_stack([marginal.from_normal(z[:, j]) for j, marginal in enumerate(self.marginals)])


def _iman_conover(z: np.ndarray, correlation: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The columns of ``z`` reordered so that their rank correlation is about ``correlation``
    (Iman & Conover 1982): van der Waerden scores with that correlation set the ranks."""
    from scipy import stats  # scipy.stats (0.5 s): only where it is used

    count, n = z.shape
    scores = stats.norm.ppf(np.arange(1, count + 1) / (count + 1))
    target = np.column_stack([rng.permutation(scores) for _ in range(n)])
    own = np.corrcoef(target, rowvar=False)
    target = target @ np.linalg.inv(np.linalg.cholesky(own)).T @ np.linalg.cholesky(correlation).T
    out = np.empty_like(z)
    for j in range(n):
        out[np.argsort(target[:, j]), j] = np.sort(z[:, j])
    return out
