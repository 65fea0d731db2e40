"""The correlation models of a random field, each one object with its correlation function.

With the scale of fluctuation ``theta`` (Vanmarcke; Fenton & Griffiths) and the lag over it,
r = sqrt((tau_x / theta_x)^2 + (tau_y / theta_y)^2):

    markov:    rho = exp(-2 r)
    gaussian:  rho = exp(-pi r^2)

(GSTools' exponential model exp(-r / l) is this Markov model with l = theta / 2.)  A field names its
model by ``[[random_field.properties]] correlation_model``, found in :data:`CORRELATION_MODELS`;
the circulant embedding (``workflows.random_field.embedding``) asks it for rho."""

from __future__ import annotations

import math

import numpy as np


class CorrelationModel:
    """One correlation model (module doc)."""

    name: str
    formula: str  # rho as the study-file reference shows it, with r the lag over theta

    def __repr__(self) -> str:
        return self.name

    def of_squared_lag(self, r2: np.ndarray) -> np.ndarray:
        """rho at the squared lags over theta ``r2``."""
        raise NotImplementedError


class Markov(CorrelationModel):
    name = "markov"
    formula = "exp(-2 r)"

    def of_squared_lag(self, r2):
        return np.exp(-2.0 * np.sqrt(r2))


class Gaussian(CorrelationModel):
    name = "gaussian"
    formula = "exp(-pi r^2)"

    def of_squared_lag(self, r2):
        return np.exp(-math.pi * r2)


MARKOV, GAUSSIAN = Markov(), Gaussian()
CORRELATION_MODELS: dict[str, CorrelationModel] = {model.name: model for model in (MARKOV, GAUSSIAN)}
"""Every correlation model, by its name in the study file."""
