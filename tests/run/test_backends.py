"""Every scene of every library model, on both backends: they must agree.

Chaotic and long scenes cannot agree to 1e-9 between two different implementations over
their whole length (errors grow like exp(Lyapunov exponent x t)), so each scene is run over its
first time unit (or its SPANS) at tight tolerances (adaptive methods) or with its own step (fixed-step
methods, the same method in C and NumPy).
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import library_model, library_scenes

SCENES = [(model, scene or "default") for model, scene in library_scenes()]
# The default run: one scene per integrator (dop853, dopri5, rk4, gauss, radau5, rkn8), one with a
# nonholonomic constraint and its projection; the other scenes are slow.
DEFAULT_SCENES = {("double_pendulum", "chaos"), ("damped_driven_pendulum", "driven"), ("wedge", "slide"),
                  ("kepler", "symplectic"), ("charged_particle", "helix"), ("pleiades", "nystrom"),
                  ("rolling_penny", "roll")}

# SciPy's Radau factors the FPU chain's 400 x 400 Newton matrices dense (C's radau5 banded, in
# O(n)): the NumPy run costs 3.5 s per tenth of a time unit at rtol 1e-12, so it is compared over
# three output rows rather than ten.
SPANS = {("fpu_chain", "implicit"): 0.3}


def run(model, scene, backend):
    m = library_model(model)
    plan = m.plan(None if scene == "default" else scene)
    tight = {} if plan.integrator.name in ("rk4", "gauss") else {"rtol": 1e-12, "atol": 1e-14}
    stop = min(plan.time.stop, plan.time.start + SPANS.get((model, scene), 1.0))
    return m.simulate(None if scene == "default" else scene, backend, stop=stop, **tight)


@pytest.mark.parametrize("model, scene", [
    pytest.param(model, scene, id=f"{model}.{scene}", marks=() if (model, scene) in DEFAULT_SCENES else pytest.mark.slow)
    for model, scene in SCENES])
def test_c_and_numpy_agree(model, scene):
    c, py = run(model, scene, "c"), run(model, scene, "numpy")
    assert c.columns == py.columns
    # the grid is the same; a scene's last row, where its stop condition held, is located by each
    # backend to the integrator's accuracy (the ladder leaves the wall at 0.8154146717113... s)
    last = len(c.t) - 1 if library_model(model).plan(None if scene == "default" else scene).stop else len(c.t)
    assert len(c.t) == len(py.t) and np.array_equal(c.t[:last], py.t[:last])
    assert np.allclose(c.t[last:], py.t[last:], rtol=1e-11, atol=0)
    scale = np.maximum(1.0, np.abs(py.values))
    # radau5 works to rtol' = 0.1 rtol^(2/3) = 1e-9 at rtol 1e-12 (as RADAU5 does; SciPy's Radau
    # to rtol itself): the velocities of the FPU chain's stiff springs agree to 2.5e-9 only
    bound = 1e-8 if library_model(model).plan(None if scene == "default" else scene) \
        .integrator.name == "radau5" else 1e-9
    assert np.max(np.abs(c.values - py.values) / scale) < bound
