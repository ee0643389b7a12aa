"""The four problems of heyoka_comparison.py for CyRK's C++ solver (nbsolve2_ivp, DOP853): each
right-hand side a numba C callback `void f(double *dy, double t, double *y, double *args)`, as
CyRK's documentation has a user write it, in the state order of heyoka_systems.py (so that the
same column indices read both tools' output).

Each function returns (the callback's address, the initial state), or None without CyRK.
"""
from __future__ import annotations

import math

import heyoka_systems


def _compile(body):
    """The address of `body` compiled as CyRK's C callback, or None without CyRK and numba."""
    try:
        from CyRK import cyjit
    except ImportError:
        return None
    return cyjit(body).address


def double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81, theta1=1.0, theta2=2.0):
    """Cramer's rule on M q'' = F for y = (theta1, theta2, theta1', theta2')."""
    def rhs(dy, t, y, args):
        d = y[0] - y[1]
        c, s = math.cos(d), math.sin(d)
        a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
        b1 = -m2 * l1 * l2 * s * y[3] * y[3] - (m1 + m2) * g * l1 * math.sin(y[0])
        b2 = m2 * l1 * l2 * s * y[2] * y[2] - m2 * g * l2 * math.sin(y[1])
        det = a11 * a22 - a12 * a12
        dy[0], dy[1] = y[2], y[3]
        dy[2] = (b1 * a22 - a12 * b2) / det
        dy[3] = (a11 * b2 - a12 * b1) / det
    return _compile(rhs), [theta1, theta2, 0.0, 0.0]


def pleiades():
    """Hairer's seven stars, star i of mass i, G = 1; y = (x, y, vx, vy), seven each."""
    n = 7

    def rhs(dy, t, y, args):
        for i in range(2 * n):
            dy[i] = y[2 * n + i]
            dy[2 * n + i] = 0.0
        for i in range(n):
            for j in range(i + 1, n):
                dx, dyy = y[j] - y[i], y[n + j] - y[n + i]
                r3 = (dx * dx + dyy * dyy) ** -1.5
                dy[2 * n + i] += (j + 1) * dx * r3
                dy[3 * n + i] += (j + 1) * dyy * r3
                dy[2 * n + j] -= (i + 1) * dx * r3
                dy[3 * n + j] -= (i + 1) * dyy * r3
    _, state, _ = heyoka_systems.pleiades_start()
    return _compile(rhs), state


def outer_solar_system(model):
    """The Sun and the five outer bodies with the lagdsl model's masses and G; y = (x, y, z,
    vx, vy, vz) per body, heyoka's nbody layout."""
    masses, gravity, state, _ = heyoka_systems.solar_system_data(model)
    n = len(masses)
    gm = tuple(gravity * m for m in masses)

    def rhs(dy, t, y, args):
        for i in range(n):
            for axis in range(3):
                dy[6 * i + axis] = y[6 * i + 3 + axis]
                dy[6 * i + 3 + axis] = 0.0
        for i in range(n):
            for j in range(i + 1, n):
                dx = y[6 * j] - y[6 * i]
                dyy = y[6 * j + 1] - y[6 * i + 1]
                dz = y[6 * j + 2] - y[6 * i + 2]
                r3 = (dx * dx + dyy * dyy + dz * dz) ** -1.5
                dy[6 * i + 3] += gm[j] * dx * r3
                dy[6 * i + 4] += gm[j] * dyy * r3
                dy[6 * i + 5] += gm[j] * dz * r3
                dy[6 * j + 3] -= gm[i] * dx * r3
                dy[6 * j + 4] -= gm[i] * dyy * r3
                dy[6 * j + 5] -= gm[i] * dz * r3
    return _compile(rhs), state


def kepler_polar(eccentricity: float):
    """r'' = r theta'^2 - 1/r^2, theta'' = -2 r' theta' / r for y = (r, theta, r', theta')."""
    def rhs(dy, t, y, args):
        dy[0], dy[1] = y[2], y[3]
        dy[2] = y[0] * y[3] * y[3] - 1.0 / (y[0] * y[0])
        dy[3] = -2.0 * y[2] * y[3] / y[0]
    return _compile(rhs), [1.0, 0.0, 0.0, math.sqrt(1 + eccentricity)]
