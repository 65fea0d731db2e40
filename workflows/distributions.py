"""The distributions a random value of a study follows, each one object with its behaviour.

A distribution is named in the study file (``[[probabilistic.variables]] distribution``, ``[[random_field.
properties]] distribution``) and found in :data:`DISTRIBUTIONS` by that name.  It knows what it is given
by (a mean and a spread, or bounds), what its mean must be, and how its value follows from a standard
normal ``z``:

    normal:            x = mean + std z
    lognormal:         x = exp(mu_ln + sigma_ln z),  sigma_ln^2 = ln(1 + V^2),  mu_ln = ln(mean) - sigma_ln^2 / 2
    uniform:           x = low + (high - low) Phi(z)
    truncated_normal:  x = F^-1(Phi(z)), F the normal of mean and std cut to [low, high]

(V = std / mean).  A random field's point law (``workflows.random_field``) is a normal or a
lognormal of a standard Gaussian field (:attr:`Distribution.field_law`); a probabilistic study's
variables (``workflows.probabilistic.sampling``) take any of them through a Gaussian copula.  The
reliability index of a sample of factors of safety is that of a normal or a lognormal F.  scipy is
imported by the methods that need it, never by the study reader.
"""

from __future__ import annotations

import math

import numpy as np


def lognormal_parameters(mean: float, cov: float) -> tuple[float, float]:
    """(mu_ln, sigma_ln) of a lognormal variable of ``mean`` and coefficient of variation ``cov``:
    sigma_ln^2 = ln(1 + cov^2), mu_ln = ln(mean) - sigma_ln^2 / 2."""
    sigma2 = math.log1p(cov * cov)
    return math.log(mean) - 0.5 * sigma2, math.sqrt(sigma2)


class Distribution:
    """One kind of distribution (module doc).  A marginal is any object with ``mean``, ``std``, ``low``
    and ``high`` (``workflows.probabilistic.sampling.Marginal``)."""

    name: str
    given_by = ""  # what it is given by, for the study-file reference (where not a mean and a spread)
    bounded = False  # it takes bounds low and high
    by_bounds = False  # it is given by its bounds alone (no mean, std or cov)
    positive = False  # its values are positive: its mean must be > 0
    field_law = False  # a random field's point law (of a standard Gaussian field)

    def __repr__(self) -> str:
        return self.name

    def frozen(self, marginal):
        """The scipy.stats distribution of ``marginal``."""
        raise NotImplementedError

    def from_normal(self, marginal, z: np.ndarray) -> np.ndarray:
        """x = F^-1(Phi(z)) of ``marginal``."""
        from scipy import stats  # scipy.stats (0.5 s): only where it is used

        return self.frozen(marginal).ppf(stats.norm.cdf(z))

    def standardised_from_normal(self, marginal, z: np.ndarray) -> np.ndarray:
        """(x - E[x]) / std(x) of x = F^-1(Phi(z)) (``sampling.Marginal.standardised_from_normal``)."""
        raise NotImplementedError

    def copula_correlation(self, a, b, rho: float) -> float | None:
        """rho_z of the copula's normals that gives ``a`` (of this distribution) and ``b`` the correlation
        ``rho`` in closed form, or None where there is none (``sampling.normal_correlation``)."""
        return None

    def gaussian_of(self, mean: float, std: float, x: float) -> float:
        """The standard normal z whose point value is ``x`` (a field's law)."""
        raise NotImplementedError

    def point_value(self, mean: float, std: float, g: float) -> float:
        """The point value of the standard normal ``g`` (a field's law)."""
        raise NotImplementedError

    def field_values(self, mean: float, std: float, g: np.ndarray) -> np.ndarray:
        """The values of a standard Gaussian field ``g`` at the particles (a field's law)."""
        raise NotImplementedError

    def reliability_index(self, mean: float, std: float) -> float:
        """beta of factors of safety of this distribution with ``mean`` and ``std``."""
        raise ValueError(f"no reliability index of a {self.name} F (normal or lognormal)")


class Normal(Distribution):
    name = "normal"
    field_law = True

    def frozen(self, marginal):
        from scipy import stats  # (0.5 s to import: only where a normal's own formula will not do)

        return stats.norm(marginal.mean, marginal.std)

    def from_normal(self, marginal, z):
        return marginal.mean + marginal.std * np.asarray(z)

    def standardised_from_normal(self, marginal, z):
        return z

    def copula_correlation(self, a, b, rho):
        """Two normals: rho itself."""
        return rho if b.distribution is NORMAL else None

    def gaussian_of(self, mean, std, x):
        return (x - mean) / std

    def point_value(self, mean, std, g):
        return mean + std * g

    def field_values(self, mean, std, g):
        return mean + std * g

    def reliability_index(self, mean, std):
        """beta = (mu_F - 1) / sigma_F."""
        return (mean - 1.0) / std


class Lognormal(Distribution):
    name = "lognormal"
    positive = True
    field_law = True

    def frozen(self, marginal):
        from scipy import stats  # (0.5 s to import: only where a lognormal's own formula will not do)

        sigma = math.sqrt(math.log1p((marginal.std / marginal.mean) ** 2))
        return stats.lognorm(sigma, scale=marginal.mean / math.sqrt(1.0 + (marginal.std / marginal.mean) ** 2))

    def from_normal(self, marginal, z):
        """exp(mu_ln + sigma_ln z) exactly."""
        sigma2 = math.log1p((marginal.std / marginal.mean) ** 2)
        return np.exp(math.log(marginal.mean) - 0.5 * sigma2 + math.sqrt(sigma2) * np.asarray(z))

    def standardised_from_normal(self, marginal, z):
        """expm1(sigma_ln z - sigma_ln^2 / 2) / V (V = sqrt(expm1(sigma_ln^2)), its COV): no subtraction
        of nearly equal numbers at a small COV."""
        sigma2 = math.log1p((marginal.std / marginal.mean) ** 2)
        return np.expm1(math.sqrt(sigma2) * z - 0.5 * sigma2) / math.sqrt(math.expm1(sigma2))

    def copula_correlation(self, a, b, rho):
        """Two lognormals: rho_z = ln(1 + rho V_1 V_2) / (sigma_ln1 sigma_ln2); ValueError where that is
        outside (-1, 1)."""
        if b.distribution is not LOGNORMAL:
            return None
        va, vb = a.std / a.mean, b.std / b.mean
        value = (math.log1p(rho * va * vb) / math.sqrt(math.log1p(va * va) * math.log1p(vb * vb))
                 if rho * va * vb > -1.0 else -math.inf)
        if not -1.0 < value < 1.0:
            raise ValueError(f"a correlation of {rho:g} is out of reach of these two lognormals")
        return value

    def gaussian_of(self, mean, std, x):
        """-inf for x <= 0."""
        mu, sigma = lognormal_parameters(mean, std / mean)
        return (math.log(x) - mu) / sigma if x > 0.0 else -math.inf

    def point_value(self, mean, std, g):
        mu, sigma = lognormal_parameters(mean, std / mean)
        return math.exp(mu + sigma * g)

    def field_values(self, mean, std, g):
        mu, sigma = lognormal_parameters(mean, std / mean)
        return np.exp(mu + sigma * g)

    def reliability_index(self, mean, std):
        """beta = ln(mu_F / sqrt(1 + V_F^2)) / sqrt(ln(1 + V_F^2)), V_F = sigma_F / mu_F."""
        v2 = (std / mean) ** 2
        return math.log(mean / math.sqrt(1.0 + v2)) / math.sqrt(math.log1p(v2))


class Uniform(Distribution):
    name = "uniform"
    given_by = "between low and high"
    bounded = True
    by_bounds = True

    def frozen(self, marginal):
        from scipy import stats

        return stats.uniform(marginal.low, marginal.high - marginal.low)

    def standardised_from_normal(self, marginal, z):
        from scipy import stats

        return (stats.norm.cdf(z) - 0.5) * math.sqrt(12.0)


class TruncatedNormal(Distribution):
    name = "truncated_normal"
    given_by = "a normal of mean and std cut to [low, high]"
    bounded = True

    def frozen(self, marginal):
        from scipy import stats

        return stats.truncnorm((marginal.low - marginal.mean) / marginal.std,
                               (marginal.high - marginal.mean) / marginal.std, marginal.mean, marginal.std)

    def standardised_from_normal(self, marginal, z):
        """That of the standard normal truncated to its bounds in stds, its upper half from the upper tail
        (Phi(z) rounds to 1 beyond z = 8.3, whose quantile is the upper bound: infinite, or far off)."""
        from scipy import stats

        standard = stats.truncnorm((marginal.low - marginal.mean) / marginal.std,
                                   (marginal.high - marginal.mean) / marginal.std)
        t = np.where(z > 0.0, standard.isf(stats.norm.sf(z)), standard.ppf(stats.norm.cdf(z)))
        return (t - standard.mean()) / standard.std()


NORMAL, LOGNORMAL, UNIFORM, TRUNCATED_NORMAL = Normal(), Lognormal(), Uniform(), TruncatedNormal()
DISTRIBUTIONS: dict[str, Distribution] = {kind.name: kind for kind in (NORMAL, LOGNORMAL, UNIFORM, TRUNCATED_NORMAL)}
"""Every distribution, by its name in the study file."""


def listed(kinds: dict[str, Distribution]) -> str:
    """The distributions of ``kinds`` as the study-file reference lists them: ```a`, `b` (...) or `c```."""
    names = [f"`{name}`" + (f" ({kind.given_by})" if kind.given_by else "") for name, kind in kinds.items()]
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"
FIELD_DISTRIBUTIONS: dict[str, Distribution] = {name: kind for name, kind in DISTRIBUTIONS.items() if kind.field_law}
"""Those a random field's point law may follow."""
