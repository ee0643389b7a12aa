"""Fits of library models to their own runs with noise; bad data located."""
from __future__ import annotations

import functools
import importlib.util
import json

import numpy as np
import pytest

from lagdsl.errors import LagError
from tests.conftest import lagc_in_process
from tests.linear.support import lagc, model

TRUE = {"l": 1.3, "b": 0.3}
NOISE = 0.01


@pytest.fixture(scope="module")
def swing(tmp_path_factory):
    """The damped driven pendulum's swing at TRUE with Gaussian noise: (t, theta), and as CSV."""
    run = model("damped_driven_pendulum").simulate(backend="numpy", stop=6, interval=0.05, **TRUE)
    theta = run["theta"] + NOISE * np.random.default_rng(7).standard_normal(len(run.t))
    path = tmp_path_factory.mktemp("fit") / "swing.csv"
    path.write_text("t [s],theta [rad]\n" + "".join(f"{t:.17g},{x:.17g}\n" for t, x in zip(run.t, theta)))
    return run.t, theta, path


@pytest.fixture(scope="module")
def lagc_fit(swing, tmp_path_factory):
    """`lagc fit` of l and b to the swing on the NumPy backend, with its JSON and (where matplotlib
    is installed) its plot: one fit shared by the tests that read its output, (Ran, directory)."""
    directory = tmp_path_factory.mktemp("lagc-fit")
    plot = ["--plot", directory / "fit.png"] if importlib.util.find_spec("matplotlib") else []
    ran = lagc_in_process("fit", model("damped_driven_pendulum").source.name, swing[2], "--fit", "l=1", "--fit",
                          "b=0.5", "--sigma", NOISE, "-o", directory / "fit.json", *plot)
    return ran, directory


def test_a_fit_recovers_the_parameters_within_three_standard_errors(swing):
    t, theta, _ = swing
    # In C: lagc_fit fits the same data on the NumPy backend, and the test after it compares the two.
    fit = model("damped_driven_pendulum").fit({"t": t, "theta": theta}, {"l": 1.0, "b": 0.5}, sigma=NOISE, backend="c")
    assert fit.success
    for name, value in TRUE.items():
        assert abs(fit.values[name] - value) < 3 * fit.stderr[name], name
        assert 0 < fit.stderr[name] < 0.2 * value
    # chi-square per degree of freedom near 1 when sigma is the noise's
    assert 0.7 < 2 * fit.cost / (len(t) - 2) < 1.3
    np.testing.assert_allclose(np.diag(fit.correlation), 1.0)
    np.testing.assert_allclose(fit.fitted["theta"] - fit.residuals["theta"], theta)


def test_lagc_fit_writes_the_json_and_the_plot(lagc_fit):
    pytest.importorskip("matplotlib")
    ran, directory = lagc_fit
    assert ran.returncode == 0, ran.stderr
    written = json.loads((directory / "fit.json").read_text())
    assert abs(written["values"]["l"] - TRUE["l"]) < 3 * written["stderr"]["l"]
    assert ran.stdout.startswith("l = ")
    assert (directory / "fit.png").read_bytes().startswith(b"\x89PNG")


def test_lagc_fit_on_the_c_backend_finds_the_numpy_fit(swing, lagc_fit, capsys):
    numpy_fit, _ = lagc_fit
    status, out, err = lagc(capsys, "fit", model("damped_driven_pendulum").source.name, swing[2], "--fit", "l=1",
                            "--fit", "b=0.5", "--sigma", NOISE, "--backend", "c")
    assert numpy_fit.returncode == 0 and status == 0, err
    assert out.splitlines()[:2] == numpy_fit.stdout.splitlines()[:2]     # l = ... ± ..., b = ... ± ... to 10 digits


@pytest.mark.parametrize("text, message", [
    ("time,theta\n0,0.2\n", "swing.csv:1:1: error: the data has no column 't'"),
    ("t,theta,phi\n0,0.2,1\n", "swing.csv:1:9: error: data column 'phi' is not an output of the scene"),
    ("t,theta\n0,0.2\n0.1,nan\n", "swing.csv:3:5: error: column 'theta' has a value that is not a finite number"),
    ("t,theta\n0,0.2\n0.1,abc\n", "swing.csv:3:5: error: 'abc' in column 'theta' is not a number"),
    ("t,theta\n0,0.2,3\n", "swing.csv:2:1: error: this row has 3 values"),
])
def test_bad_data_is_located(tmp_path, capsys, text, message):
    path = tmp_path / "swing.csv"
    path.write_text(text)
    status, _, err = lagc(capsys, "fit", model("damped_driven_pendulum").source.name, path, "--fit", "l=1")
    assert status == 1
    assert message in err
    assert "Traceback" not in err


@pytest.mark.parametrize("params, data, message", [
    ({"ll": 1.0}, {"t": [0.0, 0.1], "theta": [0.2, 0.2]}, "'ll' is neither a parameter nor a start value"),
    ({"l": 1.0}, {"t": [0.0, 0.1]}, "only the column 't'"),
    ({"l": 1.0}, {"theta": [0.2]}, "no column 't'"),
    ({"l": 1.0}, {"t": [0.0, 0.1], "theta": [0.2, np.inf]}, "not a finite number (row 1)"),
])
def test_bad_fits_in_the_api_say_why(params, data, message):
    with pytest.raises(LagError) as raised:
        model("damped_driven_pendulum").fit(data, params)
    assert message in raised.value.render()


@functools.cache
def double_pendulum_run(stop: float):
    """The chaos scene's noiseless run at m2 = l2 = 1, which every draw of noise shares."""
    return model("double_pendulum").simulate("chaos", backend="numpy", stop=stop, interval=0.05, rtol=1e-9,
                                             atol=1e-11)


def double_pendulum_data(seed: int, stop: float = 3.0):
    """The chaos scene's angles at m2 = l2 = 1 with Gaussian noise of 1% of the swing's amplitude."""
    run = double_pendulum_run(stop)
    sigma = 0.01 * np.max(np.abs(run["theta2"]))
    rng = np.random.default_rng(seed)
    return {"t": run.t, **{c: run[c] + sigma * rng.standard_normal(len(run.t)) for c in ("theta1", "theta2")}}, sigma


def fit_double_pendulum(seed: int, backend: str = "numpy"):
    data, sigma = double_pendulum_data(seed)
    return model("double_pendulum").fit(data, {"m2": 0.8, "l2": 1.2}, scene="chaos", sigma=sigma, rtol=1e-9,
                                        atol=1e-11, backend=backend)


# Slow: the fit on both backends is test_a_fit_recovers_the_parameters_within_three_standard_errors's
# and test_lagc_fit_on_the_c_backend_finds_the_numpy_fit's (the swing), the double pendulum's
# sensitivities on C test_sensitivities.py's [double_pendulum-...-c].
@pytest.mark.slow
def test_the_double_pendulum_fit_recovers_m2_and_l2_on_both_backends():
    fit, in_c = fit_double_pendulum(11), fit_double_pendulum(11, backend="c")
    for name in ("m2", "l2"):
        assert abs(fit.values[name] - 1.0) < 3 * fit.stderr[name], name
        np.testing.assert_allclose([in_c.values[name], in_c.stderr[name]], [fit.values[name], fit.stderr[name]],
                                   rtol=1e-10)


@pytest.mark.slow
def test_the_standard_errors_match_the_spread_over_noise_draws():
    """Over 50 draws the sample spread is itself known to about 1/sqrt(2*49) = 10%, so a 30% bound
    is 3 of its standard deviations. The fits run in C (the NumPy backend's fits of the same data
    agree with them to 1e-14, test_the_double_pendulum_fit_recovers_m2_and_l2_on_both_backends), 4
    times faster."""
    fits = [fit_double_pendulum(seed, backend="c") for seed in range(50)]
    for name in ("m2", "l2"):
        spread = np.std([f.values[name] for f in fits], ddof=1)
        stderr = np.mean([f.stderr[name] for f in fits])
        assert abs(stderr / spread - 1) < 0.3, (name, stderr, spread)


@pytest.mark.slow
def test_the_fit_takes_fewer_runs_than_with_finite_difference_jacobians():
    import scipy.optimize
    data, sigma = double_pendulum_data(5)
    subject, runs = model("double_pendulum"), []

    def residuals(x):
        runs.append(x)
        run = subject.simulate("chaos", backend="numpy", stop=3.0, interval=0.05, rtol=1e-9, atol=1e-11, m2=x[0],
                               l2=x[1])
        return np.concatenate([(run[c] - data[c]) / sigma for c in ("theta1", "theta2")])

    differenced = scipy.optimize.least_squares(residuals, [0.8, 1.2], x_scale="jac")
    fit = fit_double_pendulum(5)
    np.testing.assert_allclose([fit.values["m2"], fit.values["l2"]], differenced.x, rtol=1e-5)
    assert fit.nfev < len(runs)


def test_bounds_a_data_frame_and_the_integrators_options(swing):
    pandas = pytest.importorskip("pandas")
    t, theta, _ = swing
    frame = pandas.DataFrame({"theta": theta, "t": t})
    fit = model("damped_driven_pendulum").fit(frame, {"l": 1.0, "b": 0.5}, sigma=NOISE, bounds={"b": (0.0, 0.25)},
                                              integrator="dop853", rtol=1e-8)
    assert fit.values["b"] <= 0.25
    assert abs(fit.values["b"] - 0.25) < 1e-6         # the unconstrained minimum, 0.3, is outside


def test_lagc_fit_refuses_a_bad_bound_and_an_unfitted_one(swing, capsys):
    _, _, path = swing
    source = model("damped_driven_pendulum").source.name
    status, _, err = lagc(capsys, "fit", source, path, "--fit", "l=1", "--bound", "l=2")
    assert status == 1 and "--bound takes NAME=LOW:HIGH" in err
    status, _, err = lagc(capsys, "fit", source, path, "--fit", "l=1", "--bound", "b=0:1")
    assert status == 1 and "bounds given for 'b', which is not fitted" in err
    status, _, err = lagc(capsys, "fit", source, path)
    assert status == 1 and "--fit NAME=START" in err
    status, _, err = lagc(capsys, "fit", source, path, "--fit", "l=1", "--set", "b=0.3 kg")
    assert status == 1 and "kg" in err and "Traceback" not in err        # a held value's unit is checked


def test_a_run_that_fails_during_the_fit_names_the_values_tried():
    from lagdsl.errors import SimulationError
    with pytest.raises(SimulationError) as raised:
        model("damped_driven_pendulum").fit({"t": [0.0, 1.0], "theta": [0.2, 0.1]}, {"m": 0.0})
    assert "in the fit's run at m = 0" in raised.value.render()
    assert "bounds" in raised.value.render()


def test_the_documented_example_recovers_its_swing(capsys, tmp_path):
    from tests.conftest import MODELS
    swing = MODELS.parent / "docs" / "examples" / "swing.csv"
    status, out, err = lagc(capsys, "fit", MODELS / "damped_driven_pendulum.lag", swing, "--fit", "l=1", "--fit",
                            "b=0.5", "--sigma", NOISE, "-o", tmp_path / "fit.json")
    assert status == 0, err
    assert out.startswith("l = 1.299168")        # as docs/language.md shows it
    fit = json.loads((tmp_path / "fit.json").read_text())
    for name, value in TRUE.items():
        assert abs(fit["values"][name] - value) < 3 * fit["stderr"][name], name


def test_a_value_held_in_the_fit_may_carry_its_unit(swing):
    t, theta, _ = swing
    t, theta = t[:21], theta[:21]           # the first second: enough to fit l, and a third of the runs' cost
    fits = [model("damped_driven_pendulum").fit({"t": t, "theta": theta}, {"l": 1.0}, sigma=NOISE, set={"b": held},
                                                   backend="c")
            for held in (0.3, "300 mN*m*s")]
    assert fits[0].values["l"] == pytest.approx(fits[1].values["l"], rel=1e-12)
    with pytest.raises(LagError, match="kg"):
        model("damped_driven_pendulum").fit({"t": t, "theta": theta}, {"l": 1.0}, set={"b": "0.3 kg"})
