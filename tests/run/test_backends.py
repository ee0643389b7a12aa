"""Every scene of every library model, on both backends: they must agree.

Chaotic and long scenes cannot agree to 1e-9 between two different implementations over
their whole length (errors grow like exp(Lyapunov exponent x t)), so each scene is run over its
first time unit at tight tolerances (adaptive methods) or with its own step (fixed-step
methods, the same method in C and NumPy).
"""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from tests.conftest import MODELS

SCENES = [(path.stem, scene) for path in sorted(MODELS.glob("*.lag"))
          for scene in (lagdsl.load(path).scenes or ("default",))]


def run(model, scene, backend):
    m = lagdsl.load(MODELS / f"{model}.lag")
    plan = m.plan(None if scene == "default" else scene)
    tight = {} if plan.integrator.name in ("rk4", "gauss") else {"rtol": 1e-12, "atol": 1e-14}
    stop = min(plan.time.stop, plan.time.start + 1.0)
    return m.simulate(None if scene == "default" else scene, backend, stop=stop, **tight)


@pytest.mark.parametrize("model, scene", SCENES, ids=[f"{m}.{s}" for m, s in SCENES])
def test_c_and_numpy_agree(model, scene):
    c, py = run(model, scene, "c"), run(model, scene, "numpy")
    assert c.columns == py.columns
    assert np.array_equal(c.t, py.t)
    scale = np.maximum(1.0, np.abs(py.values))
    assert np.max(np.abs(c.values - py.values) / scale) < 1e-9
