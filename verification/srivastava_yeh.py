"""Srivastava & Yeh's (1991, Water Resour. Res. 27(5):753-762) analytical solution: one-dimensional
vertical infiltration toward a water table through homogeneous or layered soil of Gardner's model,
and the steady profiles (Lu & Griffiths 2004) it starts from and tends to.

**The problem.** A column 0 <= z <= L, z up from the water table (psi = 0 at z = 0), layers
z_i <= z <= z_i+1 of saturated conductivity K_s,i and water-content range dtheta_i = theta_s,i -
theta_r,i, all with one Gardner parameter alpha (the layers' pressure heads are continuous, so
their K* below are too): K = K_s,i K*, K* = exp(alpha psi), theta = theta_r,i + dtheta_i K*.  A
steady flux q0 (downward, m/s) enters the top until t = 0, qA after.  With K*, Richards' equation
is linear in each layer:

    dtheta_i dK*/dt = K_s,i (d2K*/dz2 / alpha + dK*/dz),      the downward flux q = K_s,i (dK*/dz / alpha + K*),

K* = 1 at z = 0, q = qA at z = L, and K* and q continuous across an interface.

**Steady profiles** (a flux q throughout): K* = q / K_s,i + (K*(z_i) - q / K_s,i) exp(-alpha (z - z_i)),
K*(0) = 1, so in one layer psi = ln[q / K_s + (1 - q / K_s) exp(-alpha z)] / alpha: the profile Lu &
Griffiths (2004) write in suction u_a - u_w = -gamma_w psi with the flux positive upward (derived
here from Darcy's law; the paper was not re-read).

**The series.** u = K* - K*_A (K*_A the final steady profile) = exp(-alpha z / 2) w with
dw/dt = D_i (w'' - alpha^2 w / 4), D_i = K_s,i / (alpha dtheta_i), w(0) = 0, w' + alpha w / 2 = 0 at
the top, w continuous and K_s,i (w' + alpha w / 2) continuous at an interface: a self-adjoint
problem with weight dtheta_i whose eigenfunctions w_n (eigenvalues mu_n > 0) expand the initial
difference w_0 = exp(alpha z / 2) (K*_0 - K*_A):

    K*(z, t) = K*_A(z) + exp(-alpha z / 2) sum_n c_n w_n(z) exp(-mu_n t),
    c_n = int dtheta w_0 w_n dz / int dtheta w_n^2 dz.

These are the residues of Srivastava & Yeh's Laplace-transform solution at its poles s = -mu_n
(for one layer, w_n = sin(lambda_n z) with tan(lambda_n L) = -2 lambda_n / alpha, mu_n = D (lambda_n^2
+ alpha^2 / 4), their equation for the homogeneous soil; for two layers their characteristic
equation (21a) in another normalisation).  In layer i, w = P_i c_i(z - z_i) + R_i s_i(z - z_i) with
s_i(x) = sin(k_i x) / k_i, c_i(x) = cos(k_i x), k_i^2 = mu / D_i - alpha^2 / 4 (sinh and cosh where k_i^2 < 0):
whole functions of mu, so the characteristic function F(mu) = w'(L) + alpha w(L) / 2 has no poles;
its roots are bracketed on a fine grid of sqrt(mu) and refined by Brent's method.  Three checks
that none is missed: the n-th eigenfunction has n - 1 zeros inside the column (Sturm's
oscillation theorem), Parseval's sum sum c_n^2 int dtheta w_n^2 reaches int dtheta w_0^2, and the
independent inversion of the Laplace transform (:func:`laplace_pressure_head_m`) agrees.

**The Laplace transform** of u, U(z, s) = u_0(z) / s + exp(-alpha z / 2) (E_i exp(r_i (z - z_i+1)) +
F_i exp(-r_i (z - z_i))), r_i = sqrt(alpha^2 / 4 + s / D_i) (u_0 / s solves the transformed equation:
constants and exp(-alpha z) are in the kernel of its operator), with the 2N coefficients from the
conditions at the bottom, the interfaces and the top; inverted numerically by Talbot's fixed
contour (Abate & Valko 2004): an evaluation that shares nothing with the series but the problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.optimize import brentq


@dataclass(frozen=True)
class Layer:
    """A soil layer of Gardner's model (its alpha is the column's)."""

    thickness_m: float
    saturated_conductivity_m_s: float  # K_s
    water_content_range: float  # dtheta = theta_s - theta_r


@dataclass(frozen=True)
class Column:
    """Layers from the water table up, the flux before and after t = 0 (downward, m/s)."""

    alpha_1_m: float
    layers: tuple[Layer, ...]
    initial_flux_m_s: float  # q0
    flux_m_s: float  # qA

    @property
    def height_m(self) -> float:
        return float(sum(layer.thickness_m for layer in self.layers))

    @property
    def interfaces_m(self) -> np.ndarray:
        """z_0 = 0, z_1, ..., z_N = L."""
        return np.concatenate([[0.0], np.cumsum([layer.thickness_m for layer in self.layers])])

    def layer_of(self, z_m: np.ndarray) -> np.ndarray:
        """The index of the layer holding each height (an interface: the layer below)."""
        return np.clip(np.searchsorted(self.interfaces_m, z_m, side="left") - 1, 0, len(self.layers) - 1)

    def diffusivity_m2_s(self) -> np.ndarray:
        """D_i = K_s,i / (alpha dtheta_i)."""
        return np.array([layer.saturated_conductivity_m_s / (self.alpha_1_m * layer.water_content_range)
                         for layer in self.layers])


def steady_relative_conductivity(column: Column, z_m, flux_m_s: float) -> np.ndarray:
    """K*(z) of the steady flux ``flux_m_s`` (module doc)."""
    z = np.asarray(z_m, dtype=float)
    bottom = column.interfaces_m
    k_star = np.ones_like(z)
    k_at_bottom = 1.0
    for i, layer in enumerate(column.layers):
        ratio = flux_m_s / layer.saturated_conductivity_m_s
        inside = column.layer_of(z) == i
        k_star = np.where(inside, ratio + (k_at_bottom - ratio) * np.exp(-column.alpha_1_m * (z - bottom[i])), k_star)
        k_at_bottom = ratio + (k_at_bottom - ratio) * math.exp(-column.alpha_1_m * layer.thickness_m)
    return k_star


def steady_pressure_head_m(column: Column, z_m, flux_m_s: float) -> np.ndarray:
    """psi(z) = ln K*(z) / alpha of the steady flux ``flux_m_s`` (downward; negative: evaporation)."""
    return np.log(steady_relative_conductivity(column, z_m, flux_m_s)) / column.alpha_1_m


def _sine_cosine(k2: np.ndarray, x) -> tuple[np.ndarray, np.ndarray]:
    """(sin(k x) / k, cos(k x)) continued to k^2 <= 0 (sinh(kappa x) / kappa, cosh(kappa x))."""
    k2 = np.asarray(k2, dtype=float)
    k = np.sqrt(np.abs(k2))
    kx = k * x
    safe = np.where(k > 0.0, k, 1.0)
    hyperbolic = np.where(k2 < 0.0, kx, 0.0)  # sinh and cosh only where k^2 < 0 (elsewhere they may overflow)
    sine = np.where(k2 > 0.0, np.sin(kx) / safe, np.where(k2 < 0.0, np.sinh(hyperbolic) / safe, x))
    cosine = np.where(k2 > 0.0, np.cos(kx), np.cosh(hyperbolic))
    return sine, cosine


class SrivastavaYeh:
    """The series solution of ``column`` (module doc), its eigenvalues up to ``largest_rate_1_s``."""

    def __init__(self, column: Column, earliest_time_s: float, tail: float = 40.0):
        self.column = column
        self.a = 0.5 * column.alpha_1_m
        self.diffusivity = column.diffusivity_m2_s()
        self.earliest_time_s = earliest_time_s
        self.largest_rate_1_s = tail / earliest_time_s  # exp(-mu t) < exp(-tail) beyond it
        self.eigenvalues_1_s = self._roots()

    def _shape(self, mu: np.ndarray, z: np.ndarray | None = None):
        """(w, w') at the top for each mu, or w at the heights ``z`` (mu scalar)."""
        column, a = self.column, self.a
        mu = np.asarray(mu, dtype=float)
        p, r = np.zeros_like(mu), np.ones_like(mu)  # w = 0, w' = 1 at z = 0
        values = None if z is None else np.zeros_like(z)
        interfaces = column.interfaces_m
        for i, layer in enumerate(column.layers):
            k2 = mu / self.diffusivity[i] - a * a
            if z is not None:
                inside = column.layer_of(z) == i
                sine, cosine = _sine_cosine(k2, z[inside] - interfaces[i])
                values[inside] = p * cosine + r * sine
            sine, cosine = _sine_cosine(k2, layer.thickness_m)
            w_top, slope_top = p * cosine + r * sine, -p * k2 * sine + r * cosine
            if i + 1 < len(column.layers):  # w and K_s (w' + a w) continuous
                ratio = layer.saturated_conductivity_m_s / column.layers[i + 1].saturated_conductivity_m_s
                p, r = w_top, ratio * (slope_top + a * w_top) - a * w_top
        if z is not None:
            return values
        return w_top, slope_top

    def characteristic(self, mu) -> np.ndarray:
        """F(mu) = w'(L) + alpha w(L) / 2, scaled by a positive function of mu so that it stays of order
        one (the roots are those of F)."""
        w_top, slope_top = self._shape(mu)
        return (slope_top + self.a * w_top) / np.maximum(1.0, np.hypot(w_top, slope_top))

    def _roots(self) -> np.ndarray:
        top = math.sqrt(self.largest_rate_1_s)
        # a phase k_i l_i grows by pi when sqrt(mu) grows by about pi sqrt(D_i) / l_i: 200 points per such step
        step = min(math.pi * math.sqrt(d) / layer.thickness_m for d, layer in zip(self.diffusivity, self.column.layers))
        grid = np.linspace(0.0, top, max(2000, int(200 * top / step)))[1:] ** 2
        value = self.characteristic(grid)
        change = np.flatnonzero(np.sign(value[:-1]) * np.sign(value[1:]) < 0)
        return np.array([brentq(self.characteristic, grid[i], grid[i + 1], xtol=1e-300, rtol=1e-15) for i in change])

    def eigenfunction(self, index: int, z_m) -> np.ndarray:
        """w_n at the heights ``z_m``."""
        return self._shape(np.float64(self.eigenvalues_1_s[index]), np.asarray(z_m, dtype=float))

    @cached_property
    def _quadrature(self) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre points and weights (times dtheta) over the column: panels of an eighth of the
        shortest wavelength of the last eigenfunction, 8 points each."""
        column = self.column
        k_max = math.sqrt(max(self.eigenvalues_1_s[-1] / d for d in self.diffusivity)) if self.eigenvalues_1_s.size else 1.0
        x, w = np.polynomial.legendre.leggauss(8)
        points, weights = [], []
        for i, layer in enumerate(column.layers):
            panels = max(4, int(math.ceil(layer.thickness_m * k_max / (2.0 * math.pi) * 8)))
            edges = column.interfaces_m[i] + np.linspace(0.0, layer.thickness_m, panels + 1)
            half = 0.5 * np.diff(edges)
            points.append(((edges[:-1] + edges[1:]) / 2)[:, None] + half[:, None] * x)
            weights.append(half[:, None] * w * layer.water_content_range)
        return np.concatenate(points).ravel(), np.concatenate(weights).ravel()

    @cached_property
    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(c_n, int dtheta w_n^2 dz) of every eigenfunction (module doc)."""
        z, weight = self._quadrature
        column = self.column
        w0 = np.exp(self.a * z) * (steady_relative_conductivity(column, z, column.initial_flux_m_s)
                                   - steady_relative_conductivity(column, z, column.flux_m_s))
        c, norm = [], []
        for n in range(self.eigenvalues_1_s.size):
            wn = self.eigenfunction(n, z)
            norm.append(np.sum(weight * wn * wn))
            c.append(np.sum(weight * w0 * wn) / norm[-1])
        return np.array(c), np.array(norm)

    def parseval_deficit(self) -> float:
        """1 - sum c_n^2 int dtheta w_n^2 / int dtheta w_0^2: 0 when no eigenfunction is missing (up to the
        truncation of the series)."""
        z, weight = self._quadrature
        column = self.column
        w0 = np.exp(self.a * z) * (steady_relative_conductivity(column, z, column.initial_flux_m_s)
                                   - steady_relative_conductivity(column, z, column.flux_m_s))
        c, norm = self.coefficients
        return float(1.0 - np.sum(c * c * norm) / np.sum(weight * w0 * w0))

    def interior_zeros(self) -> np.ndarray:
        """The number of sign changes of each eigenfunction inside the column (Sturm: 0, 1, 2, ...)."""
        z = np.linspace(0.0, self.column.height_m, 20 * (self.eigenvalues_1_s.size + 10) + 1)[1:-1]
        return np.array([np.count_nonzero(np.diff(np.sign(self.eigenfunction(n, z))) != 0)
                         for n in range(self.eigenvalues_1_s.size)])

    def relative_conductivity(self, z_m, time_s: float) -> np.ndarray:
        """K*(z, t) (module doc; t >= the earliest time given)."""
        if time_s < self.earliest_time_s:
            raise ValueError(f"t = {time_s!r} s: before the earliest time the series was built for")
        z = np.asarray(z_m, dtype=float)
        c, _ = self.coefficients
        total = np.zeros_like(z)
        for n, mu in enumerate(self.eigenvalues_1_s):
            total += c[n] * self.eigenfunction(n, z) * math.exp(-mu * time_s)
        return steady_relative_conductivity(self.column, z, self.column.flux_m_s) + np.exp(-self.a * z) * total

    def pressure_head_m(self, z_m, time_s: float) -> np.ndarray:
        """psi(z, t) = ln K*(z, t) / alpha."""
        return np.log(self.relative_conductivity(z_m, time_s)) / self.column.alpha_1_m


TALBOT_NODES = 32
"""Nodes of Talbot's contour: its error is about 10^(-0.6 M), its round-off exp(2M / 5) times the
machine's: about 1e-10 at 32."""


def talbot_inverse(transform, time_s: float, nodes: int = TALBOT_NODES):
    """f(t) from its Laplace transform F(s) by the fixed Talbot contour (Abate & Valko 2004):
    f(t) ~ (r / M) [F(r) e^(r t) / 2 + sum_k Re(e^(t s_k) F(s_k) (1 + i sigma_k))], r = 2M / (5t),
    s_k = r theta_k (cot theta_k + i), sigma_k = theta_k + (theta_k cot theta_k - 1) cot theta_k,
    theta_k = k pi / M.  ``transform`` takes an array of s (complex) and returns F stacked along axis 0."""
    r = 2.0 * nodes / (5.0 * time_s)
    theta = np.arange(1, nodes) * math.pi / nodes
    cot = 1.0 / np.tan(theta)
    s = np.concatenate([[r + 0j], r * theta * (cot + 1j)])
    sigma = theta + (theta * cot - 1.0) * cot
    values = transform(s)
    weights = np.concatenate([[0.5 * math.exp(r * time_s) + 0j], np.exp(time_s * s[1:]) * (1.0 + 1j * sigma)])
    return (r / nodes) * np.real(np.tensordot(weights, values, axes=(0, 0)))


def laplace_relative_conductivity(column: Column, z_m, time_s: float) -> np.ndarray:
    """K*(z, t) from the Laplace transform of u = K* - K*_A, inverted numerically (module doc)."""
    z = np.asarray(z_m, dtype=float)
    a = 0.5 * column.alpha_1_m
    d = column.diffusivity_m2_s()
    bottom = column.interfaces_m
    n_layers = len(column.layers)
    u0 = (steady_relative_conductivity(column, z, column.initial_flux_m_s)
          - steady_relative_conductivity(column, z, column.flux_m_s))
    flux_change = column.initial_flux_m_s - column.flux_m_s  # the flux of u0, the same in every layer
    where = column.layer_of(z)

    def transform(s: np.ndarray) -> np.ndarray:
        m = s.size
        r = np.sqrt(a * a + s[:, None] / d[None, :])  # (m, N), principal branch
        length = np.array([layer.thickness_m for layer in column.layers])
        decay = np.exp(-r * length)  # exp(-r_i l_i)
        ks = np.array([layer.saturated_conductivity_m_s for layer in column.layers])
        matrix = np.zeros((m, 2 * n_layers, 2 * n_layers), dtype=complex)
        rhs = np.zeros((m, 2 * n_layers), dtype=complex)
        # unknowns (E_i, F_i): the layer's part exp(-a z) (E_i exp(r_i (z - z_i+1)) + F_i exp(-r_i (z - z_i)))
        matrix[:, 0, 0], matrix[:, 0, 1] = decay[:, 0], 1.0  # U(0) = 0
        row = 1
        for i in range(n_layers - 1):  # continuity of U and of K_s (U' / alpha + U) at z_i+1
            e = math.exp(-a * bottom[i + 1])
            matrix[:, row, 2 * i], matrix[:, row, 2 * i + 1] = e, e * decay[:, i]
            matrix[:, row, 2 * i + 2], matrix[:, row, 2 * i + 3] = -e * decay[:, i + 1], -e
            row += 1
            matrix[:, row, 2 * i] = ks[i] * e * (r[:, i] + a)
            matrix[:, row, 2 * i + 1] = ks[i] * e * (a - r[:, i]) * decay[:, i]
            matrix[:, row, 2 * i + 2] = -ks[i + 1] * e * (r[:, i + 1] + a) * decay[:, i + 1]
            matrix[:, row, 2 * i + 3] = -ks[i + 1] * e * (a - r[:, i + 1])
            row += 1
        e = math.exp(-a * column.height_m)  # the flux of U at the top: that of u0 / s plus the layer's part
        last = n_layers - 1
        matrix[:, row, 2 * last] = ks[last] * e * (r[:, last] + a) / column.alpha_1_m
        matrix[:, row, 2 * last + 1] = ks[last] * e * (a - r[:, last]) * decay[:, last] / column.alpha_1_m
        rhs[:, row] = -flux_change / s
        coefficient = np.linalg.solve(matrix, rhs[..., None])[..., 0]
        big_e, big_f = coefficient[:, 0::2][:, where], coefficient[:, 1::2][:, where]
        top, low = bottom[1:][where], bottom[:-1][where]
        rz = r[:, where]
        return u0[None, :] / s[:, None] + np.exp(-a * z)[None, :] * (
            big_e * np.exp(rz * (z - top)[None, :]) + big_f * np.exp(-rz * (z - low)[None, :]))

    return steady_relative_conductivity(column, z, column.flux_m_s) + talbot_inverse(transform, time_s)


def laplace_pressure_head_m(column: Column, z_m, time_s: float) -> np.ndarray:
    """psi(z, t) from the inverted Laplace transform (module doc)."""
    return np.log(laplace_relative_conductivity(column, z_m, time_s)) / column.alpha_1_m
