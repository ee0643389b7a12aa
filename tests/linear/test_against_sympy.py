"""A and B against sympy.physics.mechanics' Linearizer (LagrangesMethod.linearize), with the
Lagrangians written out here by hand, for three library models, to 1e-10."""
from __future__ import annotations

import numpy as np
import pytest
import sympy
from sympy.physics.mechanics import LagrangesMethod, Point, ReferenceFrame, dynamicsymbols

from lagdsl.errors import LagWarning
from tests.linear.support import model


def sympy_linear(lagrangian, coordinates, point, forces=(), frame=None, inputs=()):
    """A and B of sympy's Linearizer at `point` ({q: value, q': value}), with the accelerations
    there (M q'' = f) in its operating point."""
    speeds = [q.diff(dynamicsymbols._t) for q in coordinates]
    method = LagrangesMethod(lagrangian, coordinates, forcelist=list(forces) or None, frame=frame)
    method.form_lagranges_equations()
    accelerations = method.mass_matrix.subs(point).LUsolve(method.forcing.subs(point))
    point = {**point, **{q.diff(dynamicsymbols._t, 2): a for q, a in zip(coordinates, accelerations)}}
    A, B, _ = method.linearize(q_ind=coordinates, qd_ind=speeds, A_and_B=True, op_point=point)
    A = np.array(A.evalf(30), dtype=float)
    B = np.array(B.evalf(30), dtype=float) if inputs else None
    return A, B


def test_double_pendulum_off_its_equilibrium():
    """At a state that moves (theta2' = 0.7): the velocity terms of A too."""
    t1, t2 = dynamicsymbols("theta1 theta2")
    d1, d2 = t1.diff(), t2.diff()
    m1, m2, l1, l2, g = 1, 1, 1, 1, sympy.Rational(981, 100)
    x1, y1 = l1 * sympy.sin(t1), l1 * sympy.cos(t1)
    x2, y2 = x1 + l2 * sympy.sin(t2), y1 + l2 * sympy.cos(t2)
    t = dynamicsymbols._t
    T = m1 / 2 * (x1.diff(t) ** 2 + y1.diff(t) ** 2) + m2 / 2 * (x2.diff(t) ** 2 + y2.diff(t) ** 2)
    L = T + m1 * g * y1 + m2 * g * y2
    point = {t1: 0.3, t2: -0.2, d1: 0.0, d2: 0.7}
    expected, _ = sympy_linear(L, [t1, t2], point)
    with pytest.warns(LagWarning) as warned:
        linear = model("double_pendulum").linearize(
            at={"theta1": 0.3, "theta2": -0.2, "theta1.velocity": 0.0, "theta2.velocity": 0.7})
    assert np.max(np.abs(linear.A - expected)) < 1e-10 * max(1, np.max(np.abs(expected)))
    assert {str(w.message).split(" ")[0] for w in warned} == {"the", "theta2"}      # not at rest, and moving


def test_cart_pole_with_an_input_force():
    """A and B about the upright, the open loop (gains 0), the input u a force on the cart."""
    x, th = dynamicsymbols("x theta")
    u = dynamicsymbols("u")
    M, m, l, g = 1, sympy.Rational(1, 10), sympy.Rational(1, 2), sympy.Rational(981, 100)
    t = dynamicsymbols._t
    tip = (x + l * sympy.sin(th), l * sympy.cos(th))
    L = M / 2 * x.diff(t) ** 2 + m / 2 * (tip[0].diff(t) ** 2 + tip[1].diff(t) ** 2) - m * g * l * sympy.cos(th)
    N = ReferenceFrame("N")
    cart = Point("cart")
    cart.set_vel(N, x.diff(t) * N.x)
    point = {x: 0, th: 0, x.diff(t): 0, th.diff(t): 0, u: 0}
    A_expected, B_expected = sympy_linear(L, [x, th], point, [(cart, u * N.x)], N, inputs=[u])
    gains = {"k_x": 0, "k_theta": 0, "k_v": 0, "k_omega": 0}
    linear = model("cart_pole_lqr").linearize(at={"theta": 0}, set=gains, inputs=["u"], outputs=["x", "theta"])
    assert np.max(np.abs(linear.A - A_expected)) < 1e-10 * np.max(np.abs(A_expected))
    assert np.max(np.abs(linear.B - B_expected)) < 1e-10 * np.max(np.abs(B_expected))
    assert np.array_equal(linear.C, np.eye(2, 4)) and np.array_equal(linear.Dm, np.zeros((2, 1)))


def test_charged_particle_gyroscopic_terms():
    """A velocity-dependent L (the vector potential): the gyroscopic block of A, with an input
    that scales the hill (a parameter of U, not a force: B_q = dR/dk)."""
    x, y = dynamicsymbols("x y")
    t = dynamicsymbols._t
    m, e, B, k = 1, 1, 3, sympy.Symbol("k")
    L = (m / 2 * (x.diff(t) ** 2 + y.diff(t) ** 2) + e * B / 2 * (x * y.diff(t) - y * x.diff(t))
         + k / 2 * (x ** 2 + y ** 2))
    point = {x: 0.1, y: -0.05, x.diff(t): 0, y.diff(t): 0}
    A_expected, _ = sympy_linear(L.subs(k, 2), [x, y], point)
    with pytest.warns(LagWarning, match="not an equilibrium"):
        linear = model("magnetic_saddle").linearize(at={"x": 0.1, "y": -0.05}, inputs=["k"])
    assert np.max(np.abs(linear.A - A_expected)) < 1e-10 * np.max(np.abs(A_expected))
    # R = f(k) at fixed q'' (the point is not an equilibrium): dR/dk = (x, y), through M^-1 = 1
    assert np.allclose(linear.B[2:, 0], [0.1, -0.05], rtol=1e-14)
