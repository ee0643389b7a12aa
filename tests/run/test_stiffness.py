"""Stiffness: the explicit pairs detect it and say so once, with the remedy; `auto` switches.

The stiff test problem (`models/stiff_spring.lag`): two unit masses on soft springs (k1 = 1,
k2 = 3), joined by a stiff spring K = 1e8, started in the slow normal mode, so that
x1 = cos(omega t), x2 = r cos(omega t) exactly while the fast mode (omega near 1.4e4) only limits
an explicit method's step. The chaotic double pendulum is the non-stiff counterpart. The cart of
`models/spring_cart.lag` on a spring k = 1e8 to a shaken support has its fast mode excited far
above the tolerance: undamped (c = 0) it must be resolved, and is not called stiff; overdamped
(c = 1e6) it is stiff, and radau5 steps over it.
"""
from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import LagError
from lagdsl.integrators import VERDICT_OSCILLATION, VERDICT_STIFF
from lagdsl.scene import Overrides
from tests.conftest import compiled, library_model
from tests.run.c_harness import STRICT_FLAGS, find_cc

STIFF_SPRING = Path(__file__).parent / "models" / "stiff_spring.lag"
SPRING_CART = Path(__file__).parent / "models" / "spring_cart.lag"
K1, K2, K = 1.0, 3.0, 1e8
CART_MASS, CART_SPRING, HEAVY_DAMPER = 1.0, 1e8, 1e6


@pytest.fixture(scope="module")
def spring():
    return lagdsl.load(STIFF_SPRING)


@pytest.fixture(scope="module")
def cart():
    return lagdsl.load(SPRING_CART)


@pytest.fixture(scope="module")
def pendulum():
    return library_model("double_pendulum")


def slow_mode(t: np.ndarray) -> np.ndarray:
    """x1, x2 of the slow normal mode (the model's own start), in closed form."""
    w2 = (K1 * K2 + K * (K1 + K2)) / ((K1 + K2) / 2 + K + math.sqrt(((K2 - K1) / 2) ** 2 + K ** 2))
    r = 1 + (K1 - w2) / K
    return np.column_stack([np.cos(math.sqrt(w2) * t), r * np.cos(math.sqrt(w2) * t)])


def position_error(result) -> float:
    return float(np.max(np.abs(result.values[:, :2] - slow_mode(result.t))))


@pytest.mark.parametrize("integrator", [pytest.param("dopri5", marks=pytest.mark.slow), "dop853"])
def test_explicit_pairs_report_stiffness_once_with_the_remedy(spring, integrator):
    result = spring.simulate(integrator=integrator, stop=2)
    stiffness = result.summary.stiffness
    assert stiffness is not None and 0 < stiffness.time < 0.1
    # nearly all the work of the run came after the detection
    assert stiffness.accepted > 0.99 * result.summary.count("accepted")
    assert stiffness.rhs_total == result.summary.count("rhs_evals") > stiffness.rhs_evals > 0.99 * stiffness.rhs_total
    text = result.summary.render()
    assert text.count("stiffness detected") == 1 and "--integrator radau5" in text
    assert position_error(result) < 1e-6


def test_numpy_backend_detects_stiffness_too(spring):
    result = spring.simulate(backend="numpy", stop=0.2)
    assert result.summary.stiffness is not None and result.summary.stiffness.time < 0.1
    assert result.summary.render().count("stiffness detected") == 1


@pytest.mark.parametrize("backend, stop", [("c", None), pytest.param("numpy", 3.0, marks=pytest.mark.slow)])
def test_the_chaotic_double_pendulum_is_not_stiff(pendulum, backend, stop):
    for integrator in ("dopri5", "dop853"):
        summary = pendulum.simulate(backend=backend, integrator=integrator, stop=stop).summary
        assert summary.stiffness is None and "stiff" not in summary.render()


def test_the_standalone_program_reports_stiffness_once(spring, tmp_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source, program = tmp_path / "spring.c", tmp_path / "spring"
    source.write_text(spring.emit("c").text)
    compiled([cc, *STRICT_FLAGS, str(source), "-o", str(program), "-lm"], check=True)
    done = subprocess.run([str(program), "t.stop=1"], capture_output=True, text=True, check=True)
    assert done.stderr.count("stiffness detected at t = ") == 1 and "radau5" in done.stderr


def test_auto_switches_to_radau5_on_the_stiff_spring(spring):
    auto = spring.simulate(integrator="auto")
    dop853 = spring.simulate(integrator="dop853")
    radau5 = spring.simulate(integrator="radau5")
    switches = auto.summary.switches
    assert switches.methods == ("dop853", "radau5") and switches.count == 1
    assert switches.times[0] == pytest.approx(dop853.summary.stiffness.time)
    assert switches.spans[0] == pytest.approx(switches.times[0]) and switches.spans[1] > 9.9
    assert auto.summary.stiffness is None and "auto: 1 switch (to radau5 at t = " in auto.summary.render()
    assert auto.summary.count("rhs_evals") < dop853.summary.count("rhs_evals") / 100
    assert position_error(auto) < 1e-6
    assert np.max(np.abs(auto.values[:, :2] - radau5.values[:, :2])) < 1e-6


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_auto_returns_to_dop853_when_the_stiffness_fades(spring, backend):
    # K exp(-5 t): radau5's steps fall well inside dop853's stability region near t = 2.5. The
    # NumPy backend switches as often as C only because scipy's Radau is given radau5's working
    # tolerances (0.1 rtol^(2/3)): at the user's rtol it took 20 times the steps, and auto went
    # back and forth six times. When NumPy's return comes depends on the rounding of the LU
    # factors scipy's Radau gets from OpenBLAS: with its Haswell and Zen kernels (this AMD EPYC's),
    # a Newton failure on a stale Jacobian at t = 0.488 makes Radau reject its way down to steps
    # within dop853's stability region (h rho <= AUTO_CALM), and auto returns there, by its rule, at
    # t = 0.49; with OPENBLAS_CORETYPE=Prescott, Nehalem or Sandybridge it returns at t = 2.38-2.39,
    # as C does at 2.57. Either way once, and to the same accuracy.
    auto = spring.simulate(backend=backend, integrator="auto", decay=5.0)
    dop853 = spring.simulate(integrator="dop853", decay=5.0, rtol=1e-11, atol=1e-13)
    switches = auto.summary.switches
    returned_after = 1 if backend == "c" else switches.times[0]
    assert switches.count == 2 and switches.times[0] < 0.1 and returned_after < switches.times[1] < 5
    assert switches.spans[0] + switches.spans[1] == pytest.approx(10)
    assert "to dop853 at t = " in auto.summary.render()
    assert np.max(np.abs(auto.values[:, :2] - dop853.values[:, :2])) < 1e-6


@pytest.mark.slow
def test_auto_stays_with_dop853_on_the_double_pendulum(pendulum):
    auto = pendulum.simulate(integrator="auto", stop=5, rtol=1e-10, atol=1e-12)
    dop853 = pendulum.simulate(integrator="dop853", stop=5, rtol=1e-10, atol=1e-12)
    assert auto.summary.switches.count == 0 and auto.summary.switches.spans == (pytest.approx(5), 0)
    # no switch: the very steps of dop853
    assert np.max(np.abs(auto.values - dop853.values)) < 1e-12
    assert auto.summary.count("rhs_evals") == dop853.summary.count("rhs_evals")


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_auto_switches_at_the_verdict_of_its_backends_dop853(spring, backend):
    """The rule is the same on both backends: auto switches where dop853's stiffness test gives
    its verdict (scipy's DOP853 steps a little differently from ours here, so each backend's own)."""
    result = spring.simulate(backend=backend, integrator="auto", stop=0.5)
    verdict = spring.simulate(backend=backend, stop=0.05).summary.stiffness
    switches = result.summary.switches
    assert switches.methods == ("dop853", "radau5") and switches.count == 1
    assert switches.times == (verdict.time,) and switches.spans == pytest.approx((verdict.time, 0.5 - verdict.time))
    assert position_error(result) < 1e-5


def test_a_numpy_sweep_member_with_auto_equals_its_simulate(spring):
    """Every NumPy path steps auto alike (integrators/python/auto.py): a member of a sweep switches
    where its own simulate() does, and equals it bit for bit."""
    amplitudes = [1.0, 0.5]
    sweep = spring.sweep(None, "numpy", set={"a": amplitudes}, integrator="auto", stop=0.5)
    for b, amplitude in enumerate(amplitudes):
        alone = spring.simulate(backend="numpy", integrator="auto", stop=0.5, a=amplitude)
        assert alone.summary.switches.count >= 1
        assert np.array_equal(alone.values, sweep.values[b])


def test_auto_handles_constraints_in_c_and_is_refused_by_numpy():
    model = library_model("cartesian_pendulum")
    auto = model.simulate(integrator="auto", stop=1, rtol=1e-10, atol=1e-12)
    dop853 = model.simulate(integrator="dop853", stop=1, rtol=1e-10, atol=1e-12)
    assert auto.summary.switches.count == 0 and np.max(np.abs(auto.values - dop853.values)) < 1e-12
    with pytest.raises(LagError, match="restarts its scipy solver after every projection"):
        model.simulate(backend="numpy", integrator="auto", stop=1)


@pytest.mark.slow
def test_the_auto_program_compiles_strictly(spring, tmp_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source = tmp_path / "auto.c"
    source.write_text(spring.emit("c", None, Overrides(integrator="auto")).text)
    for precision in ([], ["-DLAG_LONG_DOUBLE"]):
        done = compiled([cc, *STRICT_FLAGS, *precision, "-c", str(source), "-o", str(tmp_path / "a.o")])
        assert done.returncode == 0, done.stderr


def trials(result) -> int:
    return result.summary.count("accepted") + result.summary.count("rejected")


@pytest.mark.parametrize("backend, stop", [("c", 2.0), pytest.param("numpy", 0.15, marks=pytest.mark.slow)])
def test_an_excited_fast_vibration_must_be_resolved_and_is_not_called_stiff(cart, backend, stop):
    result = cart.simulate(backend=backend, stop=stop, max_steps=10**6)
    verdict = result.summary.stiffness
    assert verdict.kind == VERDICT_OSCILLATION and not verdict.stiff
    # the cart's vibration on the spring, about 2 pi sqrt(M/k) (the bob adds little at 1e4 rad/s)
    assert verdict.rate == pytest.approx(math.sqrt(CART_SPRING / CART_MASS), rel=0.05)
    assert verdict.amplitude > 1000
    text = result.summary.render()
    assert "a fast oscillation (period 0.000" in text and "must be resolved" in text
    assert "stiff" not in text and "radau5" not in text


@pytest.mark.parametrize("backend, stop", [("c", 0.2), ("numpy", 0.001)])
def test_an_overdamped_fast_mode_is_stiff(cart, backend, stop):
    result = cart.simulate(backend=backend, c=HEAVY_DAMPER, stop=stop, max_steps=10**6)
    verdict = result.summary.stiffness
    assert verdict.kind == VERDICT_STIFF and verdict.stiff and verdict.amplitude < 10
    # the fast eigenvalue of the overdamped spring, -c/M
    assert verdict.rate == pytest.approx(HEAVY_DAMPER / CART_MASS, rel=0.1)
    assert result.summary.render().count("stiffness detected") == 1


def test_auto_stays_with_dop853_on_the_excited_vibration(cart):
    auto = cart.simulate(integrator="auto")
    dop853 = cart.simulate(integrator="dop853")
    assert auto.summary.switches.count <= 2
    assert trials(auto) <= 1.05 * trials(dop853)
    assert np.max(np.abs(auto.values - dop853.values)) < 1e-6


def test_auto_switches_once_and_saves_work_on_the_overdamped_spring(cart):
    auto = cart.simulate(integrator="auto", c=HEAVY_DAMPER)
    dop853 = cart.simulate(integrator="dop853", c=HEAVY_DAMPER, stop=0.2, max_steps=10**6)
    switches = auto.summary.switches
    assert switches.count == 1 and switches.spans[1] > 1.99
    # dop853 needs 10 times auto's steps on a tenth of the run
    assert 10 * trials(auto) < trials(dop853)
    reference = cart.simulate(integrator="radau5", c=HEAVY_DAMPER, rtol=1e-10, atol=1e-13)
    assert np.max(np.abs(auto.values - reference.values)) < 1e-5


def test_the_standalone_program_words_the_verdict_as_lagc_does(cart, tmp_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source, program = tmp_path / "cart.c", tmp_path / "cart"
    source.write_text(cart.emit("c").text)
    compiled([cc, *STRICT_FLAGS, str(source), "-o", str(program), "-lm"], check=True)
    done = subprocess.run([str(program), "t.stop=0.3"], capture_output=True, text=True, check=True)
    lagc = cart.simulate(stop=0.3).summary.stiffness.render()
    assert lagc in done.stderr and "stiff" not in done.stderr


@pytest.mark.parametrize("damper, stop, switches", [(HEAVY_DAMPER, 0.01, 1), (0.0, 0.02, 0)])
def test_both_backends_switch_alike_on_the_cart(cart, damper, stop, switches):
    """The same rule on both backends (integrators/python/auto.py, integrators/c/auto.c): the
    overdamped cart switches to radau5 once, at the verdict of dop853's stiffness test (the same
    step on both: scipy's DOP853 and ours take the same steps up to rounding), the undamped one
    never; the summaries carry the same fields."""
    runs = [cart.simulate(backend=backend, integrator="auto", c=damper, stop=stop) for backend in ("c", "numpy")]
    c, numpy = (run.summary.switches for run in runs)
    assert c.methods == numpy.methods == ("dop853", "radau5")
    assert c.count == numpy.count == switches
    assert numpy.times == pytest.approx(c.times, rel=1e-6)
    assert numpy.spans == pytest.approx(c.spans, rel=1e-6, abs=1e-12)
    assert runs[0].summary.stiffness is None and runs[1].summary.stiffness is None
    assert np.max(np.abs(runs[0].values - runs[1].values)) < 1e-5
