"""multiplier(c) inside output expressions: the rod tension of the Cartesian pendulum.

With the constraint g = x² + y² - l² = 0, M q'' = f + Aᵀλ puts the force 2λ(x, y) = 2λl r̂ on
the bob, so the tension (pulling towards the pivot) is -2lλ. For a pendulum of length l at
angle θ from the downward vertical it is m g cos θ + m l θ'².
"""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import LagError
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile
from tests.conftest import library_model, model_file

ANGLE_PENDULUM = """model Pendulum
  parameter m = 1.0;  parameter l = 1.0;  parameter g = 9.81;  parameter theta0 = 0.5;
  coordinate theta(start = theta0);
  T = m/2*l^2*der(theta)^2;
  U = -m*g*l*cos(theta);
  output tension = m*g*cos(theta) + m*l*der(theta)^2;
  scene swing
    time(stop = 3, interval = 0.25);
    integrator dop853(rtol = 1e-11, atol = 1e-13);
    output theta, tension;
  end swing;
end Pendulum;
"""


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_rod_tension_matches_the_angle_solution(backend):
    settings = dict(stop=3.0, interval=0.25, rtol=1e-11, atol=1e-13, m=1.5, l=2.0, theta0=0.9)
    cartesian = library_model("cartesian_pendulum").simulate("swing", backend, **settings)
    angle = lagdsl.load(model_file(ANGLE_PENDULUM, "pendulum")).simulate("swing", backend, **settings)
    assert np.array_equal(cartesian.t, angle.t)
    assert cartesian["tension"] == pytest.approx(angle["tension"], rel=1e-8)
    assert cartesian["multiplier(rod)"] == pytest.approx(-angle["tension"] / (2 * 2.0), rel=1e-8)
    # and from the Cartesian state itself: cos θ = -y/l, and m l θ'² = m|v|²/l = 2(E - m g y)/l
    m, l, g, y, energy = 1.5, 2.0, 9.81, cartesian["y"], cartesian["energy"]
    assert cartesian["tension"] == pytest.approx(m * g * (-y / l) + 2 * (energy - m * g * y) / l, rel=1e-8)


def model_error(text: str) -> str:
    with pytest.raises(LagError) as caught:
        model_from_source(SourceFile("m.lag", text))
    return caught.value.render()


def rod_model(extra: str, scene_output: str = "x") -> str:
    return f"""model Rod
  parameter l = 1;
  coordinate x(start = 0.6);
  coordinate y(start = -0.8);
  T = (der(x)^2 + der(y)^2)/2;
  U = 9.81*y;
  constraint rod: x^2 + y^2 = l^2;
{extra}
  scene s
    output {scene_output};
  end s;
end Rod;
"""


def test_multiplier_in_a_scene_output_and_in_an_output_declared_before_its_constraint(tmp_path):
    text = rod_model("", "multiplier(rod), 3*multiplier(rod) - 1, pull").replace(
        "  T =", "  output pull = -2*l*multiplier(rod);\n  T =")
    path = tmp_path / "rod.lag"
    path.write_text(text, encoding="utf-8")
    result = lagdsl.load(path).simulate("s", "numpy", stop=0.5, interval=0.25)
    lam = result["multiplier(rod)"]
    assert result["3*multiplier(rod) - 1"] == pytest.approx(3 * lam - 1, rel=1e-14)
    assert result["pull"] == pytest.approx(-2 * lam, rel=1e-14)


def test_multipliers_are_refused_in_the_equations_with_one_message():
    message = model_error(rod_model("  force x = multiplier(rod);"))
    assert message.count("error:") == 1
    assert "outputs may use it" in message and "the model's equations may not" in message


def test_an_output_holding_a_multiplier_cannot_feed_the_equations():
    message = model_error(rod_model("  output pull = multiplier(rod);\n  force x = pull;"))
    assert "'pull' is an output" in message


def test_der_of_a_multiplier_is_refused():
    assert "der() of a Lagrange multiplier" in model_error(rod_model("  output rate = der(multiplier(rod));"))


def test_other_observables_inside_expressions_say_how_to_output_them():
    assert "output x, momentum(...)" in model_error(rod_model("", "2*momentum(x)"))
    assert "energy is output on its own" in model_error(rod_model("", "2*energy"))


def test_multiplier_of_a_dropped_constraint_in_an_expression(tmp_path):
    text = """model Polar
  parameter l = 1;
  coordinate theta(start = 0.5);
  let x = l*sin(theta);
  let y = -l*cos(theta);
  T = l^2*der(theta)^2/2;
  U = 9.81*y;
  constraint rod: x^2 + y^2 = l^2;
  output pull = 2*multiplier(rod);
  scene s
    output theta, pull;
  end s;
end Polar;
"""
    path = tmp_path / "polar.lag"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(LagError, match="was dropped, so it has no multiplier"):
        lagdsl.load(path).plan("s")
