"""The end-to-end example (models/cart_pole_lqr.lag, docs/numerics.md): linearize the cart-pole
about the upright, design an LQR gain with python-control, put the feedback back into the model
as a force, and run the nonlinear closed loop from 10 degrees back to the upright."""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from lagdsl.linear import analyse
from tests.linear.support import model

OPEN_LOOP = {"k_x": 0.0, "k_theta": 0.0, "k_v": 0.0, "k_omega": 0.0}
Q, R = np.diag([1.0, 10.0, 1.0, 1.0]), 1.0


@functools.cache
def lqr_design() -> tuple[dict[str, float], np.ndarray]:
    """The gains (u = -K x) and the closed-loop poles python-control designs on our A, B, once per
    session. python-control (and scipy.signal under it, 2.5 s of CPU) is imported by the tests
    that use it, not when a worker collects this module; without it they are skipped."""
    control = pytest.importorskip("control")
    linear = model("cart_pole_lqr").linearize(at={"theta": 0}, set=OPEN_LOOP, inputs=["u"], outputs=["x", "theta"])
    assert analyse(linear).verdict == "unstable"
    plant = linear.to_control()
    assert plant.ninputs == 1 and plant.noutputs == 2 and plant.nstates == 4
    gain, _, poles = control.lqr(plant, Q, R)
    return dict(zip(["k_x", "k_theta", "k_v", "k_omega"], np.asarray(gain).ravel())), np.asarray(poles)


def lqr_gains() -> dict[str, float]:
    return lqr_design()[0]


def test_the_closed_loop_modes_are_the_lqr_poles():
    """The feedback force in the model, linearized, has the poles the design promised."""
    gains, poles = lqr_design()
    modes = analyse(model("cart_pole_lqr").linearize(at={"theta": 0}, set=gains))
    assert modes.verdict == "stable"
    expected = sorted((s for s in poles if s.imag >= 0), key=abs)
    assert np.allclose([m.s for m in modes.modes], expected, rtol=1e-9)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_the_nonlinear_closed_loop_returns_to_the_upright(backend):
    gains = lqr_gains()
    result = model("cart_pole_lqr").simulate("balance", backend, set=gains)
    theta = result["theta"]
    assert abs(theta[0] - math.radians(10)) < 1e-15
    assert np.max(np.abs(theta[result.t >= 8])) < 1e-3 and np.max(np.abs(result["x"][result.t >= 10])) < 1e-2


def test_the_gains_in_the_model_file_are_the_designed_ones():
    """The file's defaults are the gains above, rounded as written."""
    written = {p.name: p.value for p in model("cart_pole_lqr").ir.parameters if p.name.startswith("k_")}
    for name, value in lqr_gains().items():
        assert abs(written[name] - value) < 5e-4 * max(1, abs(value))
