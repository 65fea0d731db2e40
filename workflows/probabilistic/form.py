"""FORM: the first-order reliability method on the FOS, by the Hasofer-Lind / Rackwitz-Fiessler iteration.

The limit state is ``g(u) = FOS(x(u)) - factor`` in the standard normal space ``u`` of the random
variables, ``x(u)`` the Nataf transform of ``workflows.probabilistic.sampling`` (``z = L u``, ``L`` the
Cholesky factor of the normals' correlation ``R_z``, ``x_j = F_j^-1(Phi(z_j))``).  Each iteration
evaluates ``g`` at its centre ``u_k`` and at ``u_k + delta e_i`` (forward differences, ``delta`` in
standard deviations of ``u``: n + 1 FOS searches, run together), linearises

    g(u) ~ g_k + grad_k . (u - u_k),

and moves to the point of that plane nearest the origin (Rackwitz & Fiessler 1978):

    beta_k+1 = (g_k - grad_k . u_k) / |grad_k|,    u_k+1 = -beta_k+1 grad_k / |grad_k|.

It stops when beta changes by less than the tolerance.  Then beta is the reliability index
(Hasofer & Lind 1974), ``u*`` the design point, ``alpha = grad / |grad| = -u* / beta`` the sensitivity
factors (alpha_i^2 the share of variable i in the variance of the linearised ``g``; positive: the
variable's increase makes the slope safer), and ``pf_FORM = Phi(-beta)``.  The first iteration, at the
mean (``u = 0``), is the mean-value FOSM index ``beta_0 = g(0) / |grad g(0)|`` (for normal variables
Hassan & Wolff's ``(F(mu) - factor) / sigma_F`` with ``sigma_F^2 = sum (dF/dx_i sigma_i)^2``).

The FOS is known to its search's bracket only: a step whose change of the FOS is within a few
brackets gives a sensitivity of noise (:func:`noisy_variables` names them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def gradient_points(centre_u: np.ndarray, step: float) -> np.ndarray:
    """(n + 1, n): the centre and the centre moved by ``step`` along each axis (module doc)."""
    centre_u = np.asarray(centre_u, float)
    return np.vstack([centre_u, centre_u + step * np.eye(centre_u.size)])


@dataclass(frozen=True)
class Linearisation:
    """One iteration (module doc): its centre, g there, the gradient, and the next point."""

    centre_u: np.ndarray
    g: float
    gradient: np.ndarray

    @classmethod
    def of(cls, centre_u: np.ndarray, g_values: np.ndarray, step: float) -> Linearisation:
        """From g at :func:`gradient_points` (its n + 1 values in that order)."""
        g_values = np.asarray(g_values, float)
        return cls(np.asarray(centre_u, float), float(g_values[0]), (g_values[1:] - g_values[0]) / step)

    @property
    def beta(self) -> float:
        """beta_k+1 = (g_k - grad_k . u_k) / |grad_k|: the distance from the origin to the linearised limit
        state (negative: the origin itself fails)."""
        return (self.g - float(self.gradient @ self.centre_u)) / float(np.linalg.norm(self.gradient))

    @property
    def alpha(self) -> np.ndarray:
        """grad / |grad|: the sensitivity factors."""
        return self.gradient / float(np.linalg.norm(self.gradient))

    @property
    def next_u(self) -> np.ndarray:
        """The point of the linearised limit state nearest the origin: -beta alpha."""
        return -self.beta * self.alpha


def converged(betas: list[float], tolerance: float) -> bool:
    """Whether the last two iterations' beta differ by at most ``tolerance``."""
    return len(betas) >= 2 and abs(betas[-1] - betas[-2]) <= tolerance


def failure_probability(beta: float) -> float:
    """pf_FORM = Phi(-beta)."""
    return 0.5 * math.erfc(beta / math.sqrt(2.0))


def noisy_variables(fos_values: np.ndarray, brackets: np.ndarray, multiple: float) -> list[int]:
    """The axes whose step changed the FOS by less than ``multiple`` times the larger of the two searches'
    brackets (``fos_values`` and ``brackets`` at :func:`gradient_points`): their sensitivity is noise."""
    fos_values, brackets = np.asarray(fos_values, float), np.asarray(brackets, float)
    change = np.abs(fos_values[1:] - fos_values[0])
    return [i for i in range(change.size) if change[i] < multiple * max(brackets[0], brackets[i + 1])]
