"""Fits of library models to their own runs with noise; bad data located."""
from __future__ import annotations

import json

import numpy as np
import pytest

from lagdsl.errors import LagError
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


def test_a_fit_recovers_the_parameters_within_three_standard_errors(swing):
    t, theta, _ = swing
    fit = model("damped_driven_pendulum").fit({"t": t, "theta": theta}, {"l": 1.0, "b": 0.5}, sigma=NOISE)
    assert fit.success
    for name, value in TRUE.items():
        assert abs(fit.values[name] - value) < 3 * fit.stderr[name], name
        assert 0 < fit.stderr[name] < 0.2 * value
    # chi-square per degree of freedom near 1 when sigma is the noise's
    assert 0.7 < 2 * fit.cost / (len(t) - 2) < 1.3
    np.testing.assert_allclose(np.diag(fit.correlation), 1.0)
    np.testing.assert_allclose(fit.fitted["theta"] - fit.residuals["theta"], theta)


def test_lagc_fit_writes_the_json_and_the_plot(swing, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    _, _, path = swing
    status, out, err = lagc(capsys, "fit", model("damped_driven_pendulum").source.name, path, "--fit", "l=1",
                            "--fit", "b=0.5", "--sigma", NOISE, "-o", tmp_path / "fit.json",
                            "--plot", tmp_path / "fit.png")
    assert status == 0, err
    written = json.loads((tmp_path / "fit.json").read_text())
    assert abs(written["values"]["l"] - TRUE["l"]) < 3 * written["stderr"]["l"]
    assert out.startswith("l = ")
    assert (tmp_path / "fit.png").read_bytes().startswith(b"\x89PNG")


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
