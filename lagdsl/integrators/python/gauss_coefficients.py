"""The Butcher tableau of s-stage Gauss-Legendre collocation (order 2s), in float64.

The same computation as the C integrator `gauss.c` does at init, so that the two backends use the
same coefficients to the last bit or two:

- nodes c_i: the zeros of the shifted Legendre polynomial P_s(2x - 1), by Newton's method on the
  three-term recurrence of P_s; only the roots x > 0 of P_s are computed and the others set by
  symmetry, so the nodes are symmetric about 1/2 (1 - x is exact for x in [1/2, 1]);
- weights b_j = 1 / ((1 - x_j^2) P_s'(x_j)^2), the Gauss weights on [0, 1];
- a_ij = int_0^{c_i} l_j, with l_j the Lagrange basis of the nodes (Hairer, Lubich, Wanner,
  Geometric Numerical Integration, 2nd ed., II.1.3, Theorem 1.4), integrated exactly by the
  s-point Gauss rule on [0, c_i] (exact for polynomials of degree 2s - 1, and l_j has degree s - 1).

`integrated_basis` gives int_0^theta l_j for any theta: the collocation polynomial for dense output
(theta in [0, 1]) and its extrapolation for the starting values of the next step (theta in [1, 2]).

`symplectic_mu` gives mu_ij = a_ij / b_j, the form of the coefficients the integrators use: the
method is symplectic iff b_i a_ij + b_j a_ji = b_i b_j, i.e. mu_ij + mu_ji = 1, and the
floating-point mu satisfy that exactly where rounded a_ij cannot (see gauss.c).
"""
from __future__ import annotations

import math

import numpy as np

EPSILON = np.finfo(float).eps
MAX_NEWTON = 100


def _legendre(s: int, x: float) -> tuple[float, float]:
    """P_s(x) and P_s'(x) by (k+1) P_{k+1} = (2k+1) x P_k - k P_{k-1}."""
    previous, current = 1.0, x
    for k in range(1, s):
        previous, current = current, ((2 * k + 1) * x * current - k * previous) / (k + 1)
    return current, s * (x * current - previous) / ((x - 1) * (x + 1))


def gauss_nodes_weights(s: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes c (increasing) and weights b of the s-point Gauss rule on [0, 1]."""
    c, b = np.empty(s), np.empty(s)
    for i in range(s // 2):
        x = math.cos(math.pi * (i + 0.75) / (s + 0.5))
        for _ in range(MAX_NEWTON):
            p, dp = _legendre(s, x)
            dx = p / dp
            x -= dx
            if abs(dx) <= EPSILON:
                break       # quadratic convergence: this last correction left x exact to round-off
        _, dp = _legendre(s, x)
        c[i], c[s - 1 - i] = (1 - x) / 2, (1 + x) / 2
        b[i] = b[s - 1 - i] = 1 / ((1 - x) * (1 + x) * dp * dp)
    if s % 2 == 1:
        _, dp = _legendre(s, 0.0)
        c[s // 2], b[s // 2] = 0.5, 1 / (dp * dp)
    return c, b


def lagrange_basis(c: np.ndarray, x) -> np.ndarray:
    """l_j(x) = prod_{m != j} (x - c_m) / (c_j - c_m), shape (s,) + shape(x); product form."""
    x = np.asarray(x, dtype=float)
    s = len(c)
    basis = np.ones((s,) + x.shape)
    for j in range(s):
        for m in range(s):
            if m != j:
                basis[j] *= (x - c[m]) / (c[j] - c[m])
    return basis


def integrated_basis(c: np.ndarray, b: np.ndarray, theta) -> np.ndarray:
    """int_0^theta l_j, shape (s,) + shape(theta), by the Gauss rule on [0, theta]."""
    theta = np.asarray(theta, dtype=float)
    total = np.zeros((len(c),) + theta.shape)
    for m in range(len(c)):
        total += b[m] * lagrange_basis(c, theta * c[m])
    return theta * total


def gauss_legendre_tableau(s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(c, b, A) of the s-stage Gauss method: A[i, j] = a_ij = int_0^{c_i} l_j."""
    if not 1 <= s <= 6:
        raise ValueError(f"gauss takes 1 to 6 stages, not {s}")
    c, b = gauss_nodes_weights(s)
    A = np.array([integrated_basis(c, b, ci) for ci in c])
    return c, b, A


def symplectic_mu(b: np.ndarray, A: np.ndarray) -> np.ndarray:
    """mu_ij = a_ij / b_j below the diagonal, mu_ji = 1 - mu_ij above it (exact: mu_ij lies in
    [1/2, 2] for i > j), mu_ii = 1/2."""
    s = len(b)
    mu = np.full((s, s), 0.5)
    for i in range(s):
        for j in range(i):
            mu[i, j] = A[i, j] / b[j]
            mu[j, i] = 1 - mu[i, j]
    return mu
