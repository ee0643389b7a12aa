"""Every run is bounded and interruptible; its inputs and its time grid are checked first.

The model is a harmonic oscillator x'' = -(k/m) x, x(0) = 1: cheap to build and to run, and
its frequency is a parameter, so a huge k makes the step size collapse at t = 0.
"""
from __future__ import annotations

import _thread
import ctypes
import math
import os
import signal
import socket
import sys
import threading
import warnings
from collections.abc import Callable

import numpy as np
import pytest

import lagdsl
from lagdsl.abi import INTERRUPTED
from lagdsl.api import Model
from lagdsl.errors import LagError, LagWarning, Setting, SimulationError, SimulationInterrupted
from lagdsl.run import interrupt as signal_handling
from lagdsl.scene import MAX_ROWS, RTOL_FLOOR, Overrides, grid_rows
from lagdsl.source import SourceFile
from tests.conftest import model_file

OSCILLATOR = """
model Oscillator
  parameter m = 1.0;
  parameter k = 1.0;
  parameter w = sqrt(k/m);
  coordinate x(start = 1.0);
  T = m/2*der(x)^2;
  U = k/2*x^2;
  scene swing
    time(stop = 1, interval = 0.25);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output x, energy;
  end swing;
end Oscillator;
"""
BACKENDS = ("c", "numpy")


@pytest.fixture(scope="module")
def oscillator():
    """The model, derived (not run from the build cache's plans, as lagdsl.load may): the Ctrl-C
    tests watch the loaded library's lag_progress_t, which must be that of the library its runs
    call, and a derived model runs only the programs it builds (_loaded_library)."""
    return Model(SourceFile.read(model_file(OSCILLATOR, "oscillator")))


# ---- the time grid ---------------------------------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("stop, interval, expected", [
    (1.0, 0.3, [0.0, 0.3, 0.6, 0.9, 1.0]),       # stop off the grid: it is still the last row
    (1.0, 5.0, [0.0, 1.0]),                       # an interval longer than the run
    (1.0, 0.25, [0.0, 0.25, 0.5, 0.75, 1.0]),     # stop on the grid: no extra row
])
def test_the_last_row_is_at_stop(oscillator, backend, stop, interval, expected):
    result = oscillator.simulate(backend=backend, stop=stop, interval=interval)
    assert result.t.tolist() == pytest.approx(expected, abs=1e-15)
    assert result.t[-1] == stop
    assert result["x"][-1] == pytest.approx(math.cos(stop), abs=1e-8)


@pytest.mark.parametrize("integrator, options", [("rk4", {"step": 0.01}), ("gauss", {"step": 0.01})])
def test_fixed_step_methods_end_at_stop_too(oscillator, integrator, options):
    for backend in BACKENDS:
        result = oscillator.simulate(backend=backend, stop=1.0, interval=0.3, integrator=integrator, **options)
        assert result.t[-1] == 1.0 and len(result.t) == 5
        assert result["x"][-1] == pytest.approx(math.cos(1.0), abs=1e-6)


def test_grid_rows_counts_a_rounded_multiple_once():
    assert grid_rows(0.0, 10.0, 0.01) == 1001
    assert grid_rows(0.1, 0.3, 0.1) == 3          # (0.3 - 0.1)/0.1 = 1.9999999999999998
    assert grid_rows(0.0, 1e-12, 1.0) == 2


@pytest.mark.parametrize("times, words", [
    ({"stop": math.inf}, "stop time must be a finite number"),
    ({"start": math.nan}, "start time must be a finite number"),
    ({"interval": 1e-300}, "1e+300 rows"),
    ({"stop": 1e9, "interval": 1e-6}, "1e+15 rows"),
])
def test_a_grid_that_does_not_fit_is_refused(oscillator, times, words):
    with pytest.raises(LagError) as error:
        oscillator.plan(overrides=Overrides(**times))
    assert words in str(error.value)
    if "rows" in words:
        assert f"limit of {MAX_ROWS:.0e}" in str(error.value) and "larger --interval" in str(error.value)


def test_a_grid_too_fine_for_the_scenes_own_interval_points_at_the_time_statement(tmp_path):
    path = tmp_path / "fine.lag"
    path.write_text(OSCILLATOR.replace("interval = 0.25", "interval = 1e-320"))
    with pytest.raises(LagError) as error:
        lagdsl.load(path).plan(overrides=Overrides(stop=0.1))
    assert "rows, more than the limit" in str(error.value)
    assert error.value.render().startswith(f"{path}:10:5: error: the output grid")


# ---- inputs ----------------------------------------------------------------------------------

@pytest.mark.parametrize("values, words", [
    ({"m": math.inf}, "cannot set 'm' to inf"),
    ({"k": math.nan}, "cannot set 'k' to nan"),
    ({"x.start": math.inf}, "cannot set 'x.start' to inf"),
    ({"m": 1e-320, "k": 1e300}, "the parameter w, computed from the others, is inf"),
])
def test_non_finite_inputs_are_refused(oscillator, values, words):
    with pytest.raises(LagError, match=words.replace("(", r"\(")):
        oscillator.simulate(set=values)


@pytest.mark.parametrize("options, words", [
    ({"rtol": -1.0}, "rtol = ...) must be a finite number >= 0"),
    ({"atol": math.nan}, "atol = ...) must be a finite number >= 0"),
    ({"rtol": math.inf}, "rtol = ...) must be a finite number >= 0"),
    ({"rtol": 0.0, "atol": 0.0}, "cannot both be 0"),
    ({"max_step": -1.0}, "max_step = ...) must be a finite number > 0"),
    ({"max_steps": 2.5}, "max_steps = ...) must be a whole number"),
])
def test_bad_tolerances_and_limits_are_refused(oscillator, options, words):
    with pytest.raises(LagError) as error:
        oscillator.simulate(**options)
    assert words in str(error.value)
    assert isinstance(error.value.diagnostics[0].span, Setting)     # the command line's fault, not the scene's


def test_a_tolerance_below_the_rounding_is_raised_with_a_warning(oscillator):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plan = oscillator.plan(overrides=Overrides(options=(("rtol", 1e-300),)))
    assert dict(plan.integrator.options)["rtol"] == RTOL_FLOOR
    assert [str(w.message) for w in caught if w.category is LagWarning] == [
        f"rtol = 1e-300 is below 10 eps; raised to {RTOL_FLOOR:.3g}"]


def test_the_numpy_backend_raises_rtol_to_scipys_floor_in_its_own_words(oscillator):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = oscillator.simulate(backend="numpy", rtol=1e-14)
    assert [w.category for w in caught] == [LagWarning]
    assert "below what scipy's solvers accept" in str(caught[0].message)
    assert dict(result.summary.settings)["rtol"] == pytest.approx(100 * np.finfo(float).eps)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("integrator", ["dopri5", "dop853", "radau5"])
def test_pure_absolute_or_relative_error_control_is_allowed(oscillator, backend, integrator):
    """x' starts at 0: under pure relative control its error weight is 0 at the start (scipy's
    choice of the first step was NaN there, and its step loop never ended). The implicit method
    needs atol > 0, as Hairer's RADAU5 does."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LagWarning)
        results = [oscillator.simulate(backend=backend, integrator=integrator, rtol=0.0, atol=1e-10)]
    if integrator == "radau5":
        with pytest.raises(LagError, match=r"radau5\(atol = ...\) must be positive"):
            oscillator.simulate(backend=backend, integrator=integrator, atol=0.0, rtol=1e-10)
    else:
        results.append(oscillator.simulate(backend=backend, integrator=integrator, atol=0.0, rtol=1e-10))
    for result in results:
        assert result["x"][-1] == pytest.approx(math.cos(1.0), abs=1e-7)


# ---- step limits -----------------------------------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
def test_the_step_limit_stops_a_run_with_its_rows(oscillator, backend):
    with pytest.raises(SimulationError) as error:
        oscillator.simulate(backend=backend, stop=100.0, max_steps=20)
    failure = error.value
    assert "step limit of 20 steps" in failure.message and "--max-steps" in failure.remedy
    assert "radau5" in failure.remedy
    assert 0 < failure.time < 100 and set(failure.state) == {"x", "x'"}
    assert 1 <= len(failure.partial.t) and failure.partial.t[-1] <= failure.time


def test_the_default_step_limit_bounds_every_run(oscillator):
    """A budget of work (the forecast stops a run that would exceed it: test_work_forecast.py)."""
    plan = oscillator.plan()
    assert plan.max_steps == 10**7
    assert oscillator.plan(overrides=Overrides(stop=5e4, interval=0.01)).max_steps == 100 * 5000001


@pytest.mark.filterwarnings("ignore::RuntimeWarning")      # scipy's first-step estimate overflows
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_step_size_collapse_at_t0_fails_at_once(oscillator, backend):
    """k = 1e300: the period is 6e-150, so the step collapses at t = 0, where 10 eps |t| is 0.
    At once: before any step is accepted (the run used to creep on with steps of 1e-150 for hours)."""
    with pytest.raises(SimulationError) as error:
        oscillator.simulate(backend=backend, k=1e300)
    assert "step size collapsed" in error.value.message
    assert error.value.time < 1e-13
    assert error.value.partial.summary.count("accepted") == 0


def test_a_numpy_run_that_cannot_finish_within_the_limit_stops_early(oscillator):
    """k = 1e10 with 200 steps allowed... of 1e7 needed: the NumPy run stops after the judged
    steps, at its pace, instead of grinding through the whole limit; its rows are kept."""
    with pytest.raises(SimulationError) as error:
        oscillator.simulate(backend="numpy", k=1e10, stop=100.0, interval=1e-4, max_steps=10**6)
    failure = error.value
    assert failure.message.startswith("at this pace reaching t = 100 would take ")
    assert failure.message.endswith("steps, more than the step limit of 1000000")
    assert "--max-steps" in failure.remedy
    assert failure.time < 1e-2 and len(failure.partial.t) >= 2


@pytest.mark.parametrize("backend", BACKENDS)
def test_max_step_is_honoured(oscillator, backend):
    result = oscillator.simulate(backend=backend, integrator="dopri5", max_step=0.01)
    assert result.summary.count("accepted") >= 100


def test_a_fixed_step_run_takes_the_steps_its_step_implies(oscillator):
    """A fixed step fixes the count (here 5e5, over the default limit of 1e5 that an adaptive run
    has): no default limit refuses it. A limit given below the count refuses it before it starts."""
    result = oscillator.simulate(integrator="rk4", step=2e-6)
    assert result.t[-1] == 1.0 and result.summary.count("accepted") == 500000
    with pytest.raises(LagError, match="would take 5e\\+05 steps .* more than the step limit of 1000"):
        oscillator.simulate(integrator="rk4", step=2e-6, max_steps=1000)
    assert len(oscillator.simulate(integrator="rk4", step=1e-3, max_steps=1000).t) == 5


# ---- Ctrl-C ----------------------------------------------------------------------------------

# Ctrl-C comes once the run has reached this time: two rows after the start of the long runs
# below (interval 10), however fast or loaded the machine.
PRESS_AT = 20.0
# about 10 s of C without progress reports (a call in the calling thread): far longer than the rows before a press
LONG_C_RUN = Overrides(stop=1e7, interval=10.0, options=(("rtol", 1e-13), ("max_steps", 1e12)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_ctrl_c_stops_a_run_and_keeps_its_rows(oscillator, backend):
    """Ctrl-C (KeyboardInterrupt in the main thread) in the integration itself: the first progress
    report past PRESS_AT presses it."""
    pressed = []

    def progress(t, start, stop):
        if t >= PRESS_AT and not pressed:
            pressed.append(t)
            _thread.interrupt_main()

    # about 10 s of C: far longer than the rows before Ctrl-C, however fast the code gets
    long_run = Overrides(stop=1e7, interval=10.0, options=(("rtol", 1e-13), ("max_steps", 1e12)))
    with pytest.raises(SimulationInterrupted) as stopped:
        oscillator.simulate_plan(None, backend, long_run, progress)
    partial = stopped.value.partial
    assert pressed[0] <= stopped.value.time < pressed[0] + 1e5     # soon after the press: within 1% of the run
    assert 1 < len(partial.t) < 1000001 and partial.t[-1] <= stopped.value.time
    assert np.all(np.diff(partial.t) == 10.0)
    assert np.allclose(partial["x"], np.cos(partial.t), atol=1e-6)


def _press_ctrl_c_when(reached: Callable[[], bool], number: int = signal.SIGINT) -> threading.Thread:
    """A thread that sends SIGINT (or `number`) to this process, as Ctrl-C does, once `reached()` holds."""
    def press() -> None:
        while not reached():
            threading.Event().wait(0.001)       # a short wait between looks: the condition decides
        os.kill(os.getpid(), number)
    presser = threading.Thread(target=press, daemon=True)
    presser.start()
    return presser


def test_ctrl_c_stops_a_c_run_made_in_the_calling_thread(oscillator):
    """Without progress reports the C call is made in the main thread itself (run/interrupt.py,
    _Guarded): a real SIGINT, sent once the run has passed PRESS_AT, still stops it with its rows,
    and leaves Python's handlers as they were."""
    reached = ctypes.c_double.in_dll(_loaded_library(oscillator), "lag_progress_t")
    reached.value = 0.0
    presser = _press_ctrl_c_when(lambda: reached.value >= PRESS_AT)
    with pytest.raises(SimulationInterrupted) as stopped:
        oscillator.simulate_plan(None, "c", LONG_C_RUN)
    presser.join()
    partial = stopped.value.partial
    assert PRESS_AT <= stopped.value.time < PRESS_AT + 1e5 and 1 < len(partial.t)
    assert np.allclose(partial["x"], np.cos(partial.t), atol=1e-6)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.set_wakeup_fd(-1) == -1


def _loaded_library(oscillator) -> ctypes.CDLL:
    oscillator.simulate_plan(None, "c", Overrides(stop=1.0))        # builds and loads the code
    return oscillator._programs[(oscillator.plan().scene_name, "dop853", "c", False)].loaded


def test_sigterm_stops_a_c_run_made_in_the_calling_thread_where_it_is_an_interrupt(oscillator, monkeypatch):
    """terminate_as_interrupt() (lagc's): SIGTERM, sent once the run has passed PRESS_AT, stops
    the guarded call as Ctrl-C does, is noted as received, and the handler is put back."""
    reached = ctypes.c_double.in_dll(_loaded_library(oscillator), "lag_progress_t")
    reached.value = 0.0
    monkeypatch.setattr(signal_handling, "_received_sigterm", False)
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal_handling.terminate_as_interrupt()
        handler = signal.getsignal(signal.SIGTERM)
        presser = _press_ctrl_c_when(lambda: reached.value >= PRESS_AT, signal.SIGTERM)
        with pytest.raises(SimulationInterrupted) as stopped:
            oscillator.simulate_plan(None, "c", LONG_C_RUN)
        presser.join()
        assert signal_handling.terminated() and signal.getsignal(signal.SIGTERM) is handler
        assert PRESS_AT <= stopped.value.time < PRESS_AT + 1e5
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_press_the_call_did_not_see_is_raised_after_it_and_one_it_saw_is_not(oscillator):
    """The guard notes a press without raising; after the call it is raised as KeyboardInterrupt
    unless the call says it was stopped by it (status INTERRUPTED)."""
    interrupt = signal_handling.RunInterrupt(_loaded_library(oscillator))

    def pressed_then(status: int) -> Callable[[], int]:
        def call() -> int:
            os.kill(os.getpid(), signal.SIGINT)
            while not interrupt.flag.value:         # the guard's handler may run in another thread
                threading.Event().wait(0.001)
            return status
        return call
    with pytest.raises(KeyboardInterrupt):
        signal_handling.interruptible(interrupt, pressed_then(0), None)
    assert signal_handling.interruptible(interrupt, pressed_then(INTERRUPTED), None)[0] == INTERRUPTED
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


class _SigAction(ctypes.Structure):
    """Linux's struct sigaction as the C library lays it out (its 1024-bit sigset_t)."""
    _fields_ = [("handler", ctypes.c_void_p), ("mask", ctypes.c_ulong * (1024 // (8 * ctypes.sizeof(ctypes.c_ulong)))),
                ("flags", ctypes.c_int), ("restorer", ctypes.c_void_p)]


def _disposition(number: int) -> tuple[int, int, int]:
    """The process's handler of signal `number` as the C library holds it: (the handler, the
    signals it blocks (the kernel's 64), its flags)."""
    held = _SigAction()
    if ctypes.CDLL(None, use_errno=True).sigaction(number, None, ctypes.byref(held)) != 0:
        raise OSError(ctypes.get_errno(), "sigaction")
    return held.handler, held.mask[0], held.flags


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="struct sigaction as Linux lays it out")
def test_a_guarded_call_puts_pythons_handler_back_whole(oscillator):
    """With its flags too: signal() would add SA_RESTART (BSD semantics) or SA_RESETHAND, and a
    blocking call would then no longer be cut short by Ctrl-C (EINTR), or a second press kill."""
    _loaded_library(oscillator)
    signal.signal(signal.SIGINT, signal.default_int_handler)        # installed afresh, by Python
    before = _disposition(signal.SIGINT)
    oscillator.simulate_plan(None, "c", Overrides(stop=1.0))        # a guarded call
    assert _disposition(signal.SIGINT) == before


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="struct sigaction as Linux lays it out")
def test_a_child_forked_during_a_guarded_call_gets_pythons_handler_back(oscillator):
    """A thread that forks while the main thread is in a guarded call: the child, which will
    never end that call, must not keep the guard's handler (os.register_at_fork runs this)."""
    interrupt = signal_handling.RunInterrupt(_loaded_library(oscillator))
    before = _disposition(signal.SIGINT)
    interrupt.enter(0)
    signal_handling._Guarded._active.append(interrupt)
    assert _disposition(signal.SIGINT) != before
    signal_handling._Guarded.forked()
    assert _disposition(signal.SIGINT) == before and not signal_handling._Guarded._active


def test_a_call_leaves_someone_elses_wakeup_descriptor_to_python_and_runs_in_a_worker(oscillator):
    """asyncio's wakeup descriptor must still see a press, so the guard (whose handler writes to
    none) stays out: the call goes to a worker thread, the descriptor left as it was."""
    interrupt = signal_handling.RunInterrupt(_loaded_library(oscillator))
    ours, theirs = socket.socketpair()
    ours.setblocking(False)
    callers = []
    replaced = signal.set_wakeup_fd(ours.fileno())
    try:
        signal_handling.interruptible(interrupt, lambda: callers.append(threading.get_ident()) or 0, None)
        assert signal.set_wakeup_fd(replaced) == ours.fileno()
    finally:
        ours.close()
        theirs.close()
    assert callers != [threading.get_ident()] and len(callers) == 1


def test_a_c_run_in_another_thread_runs_there(oscillator):
    results = []
    worker = threading.Thread(target=lambda: results.append(oscillator.simulate(stop=2.0)))
    worker.start()
    worker.join()
    assert np.allclose(results[0]["x"], np.cos(results[0].t), atol=1e-6)


class _PressesCtrlCWhenFinalised:
    """Presses Ctrl-C in its finaliser: Python raises the KeyboardInterrupt inside __del__ (as
    interrupt_main returns, or at the latest at the call after it), prints "Exception ignored"
    and drops it."""

    def __del__(self):
        _thread.interrupt_main()
        _a_call()


def _a_call() -> None:
    pass


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_ctrl_c_python_drops_in_a_finaliser_still_stops_the_run(oscillator, backend, monkeypatch):
    pressed, dropped = [], []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: dropped.append(unraisable.exc_type))

    def progress(t, start, stop):
        if not pressed:
            pressed.append(t)
            _PressesCtrlCWhenFinalised()        # freed at once: its __del__ runs here

    # Were the press lost, the C run would take 10 s and the NumPy one end at its step limit.
    steps = 1e12 if backend == "c" else 1e5
    long_run = Overrides(stop=1e7, interval=10.0, options=(("rtol", 1e-13), ("max_steps", steps)))
    with pytest.raises(SimulationInterrupted):
        oscillator.simulate_plan(None, backend, long_run, progress)
    assert dropped == [KeyboardInterrupt]


@pytest.mark.parametrize("integrator", ["dop853", "rk4"])
def test_ctrl_c_stops_a_numpy_sweep_and_keeps_the_rows_reached(oscillator, integrator, monkeypatch):
    """dop853: the three members run as one stacked system, which stops with the rows it reached;
    rk4: the members run one after another, and those not begun are marked as interrupted too.
    Ctrl-C comes from the right-hand side once the first member has reached PRESS_AT (the code
    is built before); the sweep raises SimulationInterrupted with itself as `.partial`."""
    options = {"rtol": 1e-13} if integrator == "dop853" else {"step": 1e-2}
    grid = dict(stop=1e5, interval=10.0, integrator=integrator, max_steps=10**9, **options)
    oscillator.sweep(backend="numpy", set={"k": [1.0]}, **{**grid, "stop": 0.1})     # builds the code
    code = Overrides(integrator=integrator, options=tuple(options.items()))
    module = oscillator._program(None, oscillator.plan(None, code), "numpy", code).loaded
    pressed, rhs = [], module.rhs

    def pressing_rhs(t, *arguments):
        if t >= PRESS_AT and not pressed:
            pressed.append(t)
            _thread.interrupt_main()
        return rhs(t, *arguments)

    monkeypatch.setattr(module, "rhs", pressing_rhs)
    with pytest.raises(SimulationInterrupted) as stopped:
        oscillator.sweep(backend="numpy", set={"k": [1.0, 1.0, 1.0]}, **grid)
    sweep = stopped.value.partial
    assert list(sweep.status) == ["interrupted"] * 3
    begun = sweep.rows > 0
    assert begun[0] and 1 < sweep.rows[0] < len(sweep.t)
    assert list(begun) == ([True] * 3 if integrator == "dop853" else [True, False, False])
    reached = sweep.rows[0]
    assert np.allclose(sweep["x"][0, :reached], np.cos(sweep.t[:reached]), atol=1e-6)
