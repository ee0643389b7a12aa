"""The work forecast (lagdsl/integrators/forecast.py): an adaptive run stops when its pace
forecasts more steps than its step limit, by one rule on both backends; long legitimate runs
(tests/run/models/long_runs, the excited scene of stiff_spring.lag) finish with their defaults
(in C to the end; on NumPy, whose runs take minutes, forecast to finish over their first steps),
and a runaway stops after about a thousand steps with the forecast it reached."""
from __future__ import annotations

import math
import subprocess
import warnings
from pathlib import Path

import pytest

import lagdsl
from lagdsl.abi import HOPELESS
from lagdsl.codegen.c_abi import runtime_contract, runtime_header
from lagdsl.errors import SimulationError
from lagdsl.integrators import c_file
from lagdsl.integrators.forecast import WorkForecast
from lagdsl.settings import FORECAST_JUDGED_AFTER, FORECAST_WINDOW
from tests.conftest import compiled, library_model
from tests.run.c_harness import STRICT_FLAGS, SYSTEM_HEADERS, find_cc

HERE = Path(__file__).parent / "models"
LONG_RUNS = HERE / "long_runs"


# ---- the rule --------------------------------------------------------------------------------

def verdicts(forecast: WorkForecast, steps) -> list[bool]:
    return [forecast.hopeless(h, t) for h, t in steps]


def test_the_forecast_forgives_a_burst_of_small_steps_and_a_fast_start():
    perihelion = WorkForecast(0.0, 100.0, 10**5)       # steady 1e-2 steps, then a burst of 1e-6
    burst = [(1e-2, 1e-2 * n) for n in range(1, 2001)] + [(1e-6, 20.0 + 1e-6 * n) for n in range(1, 201)]
    assert not any(verdicts(perihelion, burst))
    transient = WorkForecast(0.0, 100.0, 10**5)        # 900 tiny steps, then large ones
    start = [(1e-9, 1e-9 * n) for n in range(1, 901)] + [(1e-2, 1e-2 * n) for n in range(1, 2000)]
    assert not any(verdicts(transient, start))


def test_a_run_whose_steps_stay_tiny_is_hopeless_once_judged():
    stuck = WorkForecast(0.0, 100.0, 10**5)            # 1e-9 for good: 1e11 steps to go
    said = verdicts(stuck, [(1e-9, 1e-9 * n) for n in range(1, FORECAST_JUDGED_AFTER + 1)])
    assert not any(said[:-1]) and said[-1]
    assert stuck.steps == pytest.approx(1e11)


def test_a_long_run_at_a_steady_pace_goes_on_to_its_limit():
    """1e6 steps forecast against a limit of 1e7: never hopeless, whatever the count so far."""
    steady = WorkForecast(0.0, 1e4, 10**7)
    assert not any(verdicts(steady, [(1e-2, 1e-2 * n) for n in range(1, 20001)]))
    assert steady.steps == pytest.approx(1e6)


# Step sequences both implementations read: (h, t) with t the sum of the steps, made in C by the
# same arithmetic (a geometric shrink, a steady pace with a burst, a stall).
C_MAIN = r"""
static void run(const char *name, real h0, real factor, long burst_from, long count, long budget)
{
    lag_forecast forecast;
    real h = h0, t = 0;
    long n;
    memset(&forecast, 0, sizeof forecast);
    forecast.start = 0;
    forecast.stop = 100;
    forecast.budget = budget;
    for (n = 1; n <= count; ++n) {
        real step = n >= burst_from ? h * LAG_LIT(1e-4) : h;
        t += step;
        if (lag_forecast_step(&forecast, step, t) != LAG_OK)
            break;
        h *= factor;
    }
    printf("%s %ld %.17g\n", name, n, (double)forecast.steps);
}

int main(void)
{
    (void)r_isfinite;
    (void)lag_print_real;
    run("shrink", LAG_LIT(1e-2), LAG_LIT(0.999), 1000000, 100000, 100000);
    run("burst", LAG_LIT(1e-2), LAG_LIT(1.0), 2000, 2400, 100000);
    run("stall", LAG_LIT(1e-9), LAG_LIT(1.0), 1000000, 5000, 100000);
    run("long", LAG_LIT(2e-3), LAG_LIT(1.0), 1000000, 30000, 100000);
    return 0;
}
"""


def python_run(h0: float, factor: float, burst_from: int, count: int, budget: int) -> tuple[int, float]:
    forecast, h, t = WorkForecast(0.0, 100.0, budget), h0, 0.0
    for n in range(1, count + 1):
        step = h * 1e-4 if n >= burst_from else h
        t += step
        if forecast.hopeless(step, t):
            return n, forecast.steps
        h *= factor
    return count + 1, forecast.steps


def test_the_c_forecast_is_the_python_forecast(tmp_path):
    """lag_forecast_step (forecast.c) and WorkForecast stop the same sequences at the same step with
    the same forecast, to the last bit."""
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source, program = tmp_path / "forecast.c", tmp_path / "forecast"
    source.write_text("\n".join([SYSTEM_HEADERS, runtime_header(), runtime_contract(), c_file("forecast.c"), C_MAIN]))
    compiled([cc, *STRICT_FLAGS, str(source), "-o", str(program), "-lm"], check=True)
    printed = subprocess.run([str(program)], check=True, capture_output=True, text=True).stdout.split("\n")
    runs = {"shrink": (1e-2, 0.999, 1000000, 100000, 100000), "burst": (1e-2, 1.0, 2000, 2400, 100000),
            "stall": (1e-9, 1.0, 1000000, 5000, 100000), "long": (2e-3, 1.0, 1000000, 30000, 100000)}
    for line in filter(None, printed):
        name, step, steps = line.split()
        n, forecast = python_run(*runs[name])
        assert (int(step), float(steps)) == (n, forecast), name
    stopped = {line.split()[0]: int(line.split()[1]) for line in printed if line}
    assert stopped["stall"] == FORECAST_JUDGED_AFTER and stopped["burst"] == 2401 and stopped["long"] == 30001
    assert stopped["shrink"] < 100000       # the steps shrink for good: stopped once judged hopeless


# ---- long legitimate runs finish -------------------------------------------------------------

def finished(path: Path, scene: str | None, backend: str):
    model = lagdsl.load(path)
    result = model.simulate(scene, backend)
    assert result.t[-1] == model.plan(scene).time.stop
    return result


@pytest.mark.parametrize("path, scene", [
    (LONG_RUNS / "kepler_orbits.lag", None),          # 1e6 fixed steps: no default limit refuses them
    (HERE / "stiff_spring.lag", "excited"),           # 1.5e5 radau5 steps (stopped at t = 6.6 before)
    (LONG_RUNS / "chaotic_pendulum.lag", None),       # 2.5e5 dop853 steps (stopped at t = 1979 before)
    (LONG_RUNS / "driven_cart.lag", None),            # auto through the excited k = 1e8 spring
])
def test_long_runs_finish_with_their_defaults_on_the_c_backend(path, scene):
    result = finished(path, scene, "c")
    assert result.summary.count("accepted") > 100000 or path.stem == "driven_cart"


class _Judged(Exception):
    """Ends a NumPy run once its forecast has been judged often enough (the test's own stop)."""


def judged_forecasts(monkeypatch, judgments: int) -> list[float]:
    """The forecasts the NumPy backend's step loop judges, each appended as it is judged; the run
    is ended by _Judged after `judgments` of them, whatever their verdict."""
    from lagdsl.run import scipy_steps
    forecasts: list[float] = []

    class Recorded(WorkForecast):
        def hopeless(self, step: float, t: float) -> bool:
            verdict = super().hopeless(step, t)
            if self.taken >= FORECAST_JUDGED_AFTER and self.taken % FORECAST_WINDOW == 0:
                forecasts.append(math.inf if verdict else self.steps)
                if len(forecasts) == judgments:
                    raise _Judged
            return verdict

    monkeypatch.setattr(scipy_steps, "WorkForecast", Recorded)
    return forecasts


@pytest.mark.slow
@pytest.mark.parametrize("path, judgments, steps", [
    # scipy's DOP853, 2900 steps of some 9e4 (3.5 ms each): forecasts 5e4 to 9e4
    (LONG_RUNS / "chaotic_pendulum.lag", 20, 2e4),
    # auto stays with scipy's DOP853, as the C auto stays with dop853: 1900 steps, forecasts 2.2e4 to 2.5e4
    (LONG_RUNS / "driven_cart.lag", 10, 1e4),
])
def test_long_runs_are_forecast_to_finish_with_their_defaults_on_the_numpy_backend(monkeypatch, path, judgments,
                                                                                    steps):
    """The whole runs take minutes of scipy steps (the C backend's run them to the end above): the
    NumPy backend's forecast, judged `judgments` times with the scenes' default step limit, forecasts
    a run of its own length (more than `steps`), far below the limit, and never stops it."""
    forecasts = judged_forecasts(monkeypatch, judgments)
    model = lagdsl.load(path)
    with pytest.raises(_Judged):
        model.simulate(None, "numpy")
    assert len(forecasts) == judgments
    assert steps < min(forecasts) and max(forecasts) < model.plan().max_steps / 10


def forecast_failure(model, scene, backend, **settings) -> SimulationError:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # the NumPy backend's own words on scipy's tolerances
        with pytest.raises(SimulationError) as caught:
            model.simulate(scene, backend, **settings)
    return caught.value


# NumPy's cart is slow (its thousand steps before the forecast is judged take scipy 4 s): the
# runaway below keeps the NumPy backend's forecast in the default run.
@pytest.mark.parametrize("backend", ["c", pytest.param("numpy", marks=pytest.mark.slow)])
def test_the_backends_stop_the_cart_by_one_rule(backend):
    """The cart needs more than 2e4 steps on either backend (2.7e4 in C; auto stays with dop853 on both): with that
    limit both stop on the forecast, early, with the forecast in the message; with the default
    both go on (test_long_runs_finish_...)."""
    cart = lagdsl.load(LONG_RUNS / "driven_cart.lag")
    failure = forecast_failure(cart, None, backend, max_steps=20000)
    assert failure.status == HOPELESS and failure.forecast > 20000
    assert failure.message.startswith("at this pace reaching t = 2 would take ")
    assert failure.message.endswith(f"steps, more than the step limit of 20000")
    assert failure.time < 2 and len(failure.partial.t) >= 1


# ---- runaways stop, with their forecast and a remedy that fits ---------------------------------

@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_runaway_stops_with_the_forecast_it_reached(backend):
    """g = 1e12 on the pendulum: omega = 1e6 rad/s, some 7e7 steps to its stop. The run stops
    once judged, about a thousand steps in, naming the forecast, the stop time and the limit."""
    pendulum = library_model("pendulum")
    failure = forecast_failure(pendulum, None, backend, g=1e12)
    stop = pendulum.plan().time.stop
    assert failure.status == HOPELESS and failure.forecast > 2e7
    assert f"at this pace reaching t = {stop:g} would take {failure.forecast:.3g} steps" in failure.message
    assert "step limit of 10000000" in failure.message
    assert "raise --max-steps" in failure.remedy and "--integrator radau5" in failure.remedy
    assert failure.partial.summary.count("accepted") <= 2 * FORECAST_JUDGED_AFTER


def test_a_radau5_run_is_not_told_to_try_radau5():
    spring = lagdsl.load(HERE / "stiff_spring.lag")
    failure = forecast_failure(spring, "excited", "c", max_steps=10000)
    assert failure.status == HOPELESS and "would take" in failure.message
    assert "radau5" not in failure.remedy and "loosen --rtol" in failure.remedy
