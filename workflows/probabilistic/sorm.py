"""SORM: FORM's probability of failure corrected by the curvatures of the limit state at the design point.

In the standard normal space ``u`` the limit state ``g(u)`` (failure ``g < 0``) has FORM's design point
``u* = beta e`` (``e = u* / |u*|``, the unit vector from the origin to it).  Rotate to ``v = R u`` with ``R``
orthogonal and its last row ``e``: ``u*`` is ``v = (0, ..., 0, beta)``, and ``v_1 .. v_n-1`` span the
tangent plane.  Near ``u*`` the limit state is the paraboloid

    v_n = beta + 1/2 sum_ij kappa_ij v_i v_j,    kappa = H_t / |grad g|,

``H_t`` the (n-1) x (n-1) Hessian of ``g`` in the tangent plane and ``|grad g|`` its gradient's length at
``u*`` (a positive curvature bends the limit state away from the origin: less fails than FORM's plane
says).  With ``kappa_i`` the eigenvalues of ``kappa`` (the principal curvatures):

    pf_Breitung = Phi(-beta) prod_i (1 + beta kappa_i)^(-1/2)                 (Breitung 1984)
    pf_HR       = Phi(-beta) prod_i (1 + psi(beta) kappa_i)^(-1/2),  psi = phi(beta) / Phi(-beta)
                                                                   (Hohenbichler, Gollwitzer, Kruse & Rackwitz 1987)

and ``beta_SORM = -Phi^-1(pf_SORM)``.  Breitung's is the asymptote as beta -> infinity at fixed
``beta kappa_i``; Hohenbichler-Rackwitz's replaces beta by ``psi(beta) > beta`` (the mean of ``v_n`` beyond
beta), exact to higher order at the moderate beta of slopes.  Both need every ``1 + beta kappa_i > 0`` (resp.
with psi): a limit state that curves toward the origin as much as the sphere of radius beta has no such
asymptote (:func:`breitung` and :func:`hohenbichler_rackwitz` give None).

``H_t`` comes from g sampled about ``u*`` by central differences of step ``h`` along the tangent axes
(:func:`curvature_points`): ``H_ii = (g(+h e_i) - 2 g(0) + g(-h e_i)) / h^2`` and ``H_ij = (g(+h,+h) -
g(+h,-h) - g(-h,+h) + g(-h,-h)) / (4 h^2)``, the gradient's tangent components ``(g(+h e_i) - g(-h e_i)) /
(2 h)`` and its normal one likewise along ``e``: 1 + 2(n-1)^2 + 2 evaluations.  g known to ``+-
half_bracket`` each bounds every entry's error (the sum of its terms' bounds), so the eigenvalues' error by
the Frobenius norm of those bounds over ``|grad g|`` (:attr:`Curvatures.noise`): the step must make the
curvatures stand above it.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy import stats


def rotation(design_u: np.ndarray) -> np.ndarray:
    """(n, n) orthogonal ``R`` whose last row is ``u* / |u*|`` (module doc), the others an orthonormal basis of
    the tangent plane: Gram-Schmidt (QR) on ``e`` and the axes but the one ``e`` leans on most."""
    design_u = np.asarray(design_u, float)
    e = design_u / float(np.linalg.norm(design_u))
    others = np.delete(np.eye(e.size), int(np.argmax(np.abs(e))), axis=1)
    q, _ = np.linalg.qr(np.column_stack([e, others]))
    q = q * float(np.sign(q[:, 0] @ e))  # (QR's signs are its own)
    return np.vstack([q[:, 1:].T, q[:, 0]])


def _offsets(n: int) -> np.ndarray:
    """(m, n) the sampled offsets in the rotated coordinates ``v`` (module doc), in units of the step: the
    centre, +- each tangent axis, the four corners of each pair of tangent axes, +- the normal."""
    t = n - 1
    rows = [np.zeros(n)]
    for i in range(t):
        for sign in (1.0, -1.0):
            rows.append(sign * np.eye(n)[i])
    for i, j in combinations(range(t), 2):
        for si, sj in ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)):
            rows.append(si * np.eye(n)[i] + sj * np.eye(n)[j])
    rows += [np.eye(n)[t], -np.eye(n)[t]]
    return np.array(rows)


def curvature_points(design_u: np.ndarray, step: float) -> np.ndarray:
    """(1 + 2(n-1)^2 + 2, n): where to evaluate g, in ``u`` (module doc; ``kinds.sorm_searches`` counts them for
    the study's budget)."""
    design_u = np.asarray(design_u, float)
    return design_u + step * _offsets(design_u.size) @ rotation(design_u)


@dataclass(frozen=True)
class Curvatures:
    """The limit state's second-order shape at the design point (module doc), from g at
    :func:`curvature_points`."""

    beta: float
    hessian: np.ndarray  # (n-1, n-1) H_t, in g per u^2
    gradient: np.ndarray  # (n,) in the rotated coordinates, the normal component last
    noise_hessian: np.ndarray  # (n-1, n-1) the bound of each entry's error

    @classmethod
    def of(cls, design_u: np.ndarray, g_values: np.ndarray, step: float,
           half_brackets: np.ndarray | None = None) -> Curvatures:
        """From g (and the bound of each value's error, ``half_brackets``) at :func:`curvature_points`."""
        design_u = np.asarray(design_u, float)
        n, t = design_u.size, design_u.size - 1
        g = np.asarray(g_values, float)
        err = np.zeros_like(g) if half_brackets is None else np.abs(np.asarray(half_brackets, float))
        hessian, noise = np.zeros((t, t)), np.zeros((t, t))
        gradient = np.zeros(n)
        for i in range(t):
            plus, minus = 1 + 2 * i, 2 + 2 * i
            hessian[i, i] = (g[plus] - 2.0 * g[0] + g[minus]) / step**2
            noise[i, i] = (err[plus] + 2.0 * err[0] + err[minus]) / step**2
            gradient[i] = (g[plus] - g[minus]) / (2.0 * step)
        k = 1 + 2 * t
        for i, j in combinations(range(t), 2):
            corners = slice(k, k + 4)
            hessian[i, j] = hessian[j, i] = float(np.array([1.0, -1.0, -1.0, 1.0]) @ g[corners]) / (4.0 * step**2)
            noise[i, j] = noise[j, i] = float(err[corners].sum()) / (4.0 * step**2)
            k += 4
        gradient[t] = (g[k] - g[k + 1]) / (2.0 * step)
        return cls(float(np.linalg.norm(design_u)), hessian, gradient, noise)

    @property
    def gradient_norm(self) -> float:
        return float(np.linalg.norm(self.gradient))

    @property
    def outward(self) -> bool:
        """Whether g decreases away from the origin through u* (failure beyond it): else u* is no design point."""
        return bool(self.gradient[-1] < 0.0)

    @property
    def kappas(self) -> np.ndarray:
        """The principal curvatures: the eigenvalues of H_t / |grad g|, ascending."""
        return np.linalg.eigvalsh(self.hessian / self.gradient_norm)

    @property
    def noise(self) -> float:
        """The bound of every principal curvature's error: |noise_hessian|_F / |grad g| (module doc)."""
        return float(np.linalg.norm(self.noise_hessian)) / self.gradient_norm


def _corrected(beta: float, kappas: np.ndarray, factor: float) -> float | None:
    terms = 1.0 + factor * np.asarray(kappas, float)
    if (terms <= 0.0).any():
        return None
    return float(stats.norm.sf(beta) * np.prod(terms ** -0.5))


def breitung(beta: float, kappas: np.ndarray) -> float | None:
    """pf = Phi(-beta) prod (1 + beta kappa_i)^(-1/2) (Breitung 1984); None where some 1 + beta kappa_i <= 0."""
    return _corrected(beta, kappas, beta)


def hohenbichler_rackwitz(beta: float, kappas: np.ndarray) -> float | None:
    """pf = Phi(-beta) prod (1 + psi kappa_i)^(-1/2), psi = phi(beta) / Phi(-beta) (module doc); None where some
    1 + psi kappa_i <= 0."""
    return _corrected(beta, kappas, float(stats.norm.pdf(beta) / stats.norm.sf(beta)))


def index(pf: float) -> float:
    """beta = -Phi^-1(pf)."""
    return float(-stats.norm.ppf(pf))


def range_from_noise(beta: float, kappas: np.ndarray, noise: float) -> tuple[float | None, float | None]:
    """Breitung's pf with every curvature raised, then lowered, by its noise bound: (the lowest pf, the highest);
    None where 1 + beta kappa > 0 breaks (pf falls as any curvature rises)."""
    kappas = np.asarray(kappas, float)
    return breitung(beta, kappas + noise), breitung(beta, kappas - noise)
