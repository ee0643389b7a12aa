"""Units: the annotation parser (located errors), the dimensions and SI factors of unit names,
the dimensional analysis of models, values converted to SI, units in `lagc check` and the CSV."""
from __future__ import annotations

import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
import sympy

from lagdsl.api import Model
from lagdsl.frontend.dimensions import Form, Solver
from lagdsl.errors import LagError
from lagdsl.pipeline import load_model, model_from_source
from lagdsl.scene import Overrides
from lagdsl.source import SourceFile, Span
from lagdsl.frontend.units import Dimension, dimension, in_si, parse_unit
from tests.conftest import MODELS, lagc_in_process


def unit_span(unit: str) -> Span:
    """The span of `unit` (brackets included) in a one-line parameter declaration."""
    text = f"  parameter p = 1 {unit};\n"
    start = text.index("[")
    return Span(SourceFile("units.lag", text), 1, start + 1, start, start + len(unit))


@pytest.mark.parametrize("unit, factors", [
    ("[kg]", {"kg": 1}),
    ("[m/s^2]", {"m": 1, "s": -2}),
    ("[kg*m^2]", {"kg": 1, "m": 2}),
    ("[1/s]", {"s": -1}),
    ("[m^3/(kg*s^2)]", {"m": 3, "kg": -1, "s": -2}),
    ("[N*m*s]", {"N": 1, "m": 1, "s": 1}),
    ("[1]", {}),
    ("[m^(1/2)]", {"m": Fraction(1, 2)}),
    ("[kg**2/m^-1]", {"kg": 2, "m": 1}),
])
def test_units_parse_to_base_factors(unit, factors):
    parsed = parse_unit(unit_span(unit))
    assert dict(parsed.factors) == {name: Fraction(power) for name, power in factors.items()}
    assert parsed.text == unit[1:-1]


@pytest.mark.parametrize("unit, column, message", [
    ("[kg/]", 23, "the unit ends too early: expected a unit name after '/'"),
    ("[m/s^]", 24, "the unit ends too early: expected an exponent after '^'"),
    ("[N m]", 22, "expected '*', '/' or the end of the unit, found 'm'"),
    ("[m^x]", 22, "expected a number as unit exponent, found 'x'"),
    ("[m^(1/0)]", 25, "division by zero in a unit exponent"),
    ("[2]", 20, "unexpected '2' in unit: the only number allowed is 1, as in [1/s], or an exponent"),
    ("[(m]", 22, "the unit ends too early: expected ')' after 'm'"),
    ("[kg%]", 22, "unexpected character '%' in unit"),
    ("[]", 19, "empty unit: write [1] for a dimensionless quantity"),
])
def test_malformed_units_give_located_errors(unit, column, message):
    with pytest.raises(LagError) as raised:
        parse_unit(unit_span(unit))
    diagnostic, = raised.value.diagnostics
    assert diagnostic.message == message
    assert (diagnostic.span.line, diagnostic.span.column) == (1, column)
    assert "^" in diagnostic.render().splitlines()[-1]


# -- dimensional analysis and SI values (dimensions.py) ----------------------------------------

PENDULUM = """model Pendulum
  parameter m = {m};
  parameter l = {l};
  parameter g = 9.81 [m/s^2];
  parameter b = {b};
  coordinate theta(start = {start}, velocity = {velocity}) [{angle}];
  T = m*l^2/2*der(theta)^2;
  U = -m*g*l*cos(theta);
  dissipation = b/2*der(theta)^2;
  output x = l*sin(theta) [{x}];
  scene swing
    time(stop = 1, interval = 0.25);
    integrator dop853(rtol = 1e-12, atol = 1e-14);
    output theta, x, energy;
  end swing;
end Pendulum;
"""
PENDULUM_SI = PENDULUM.format(m="0.5 [kg]", l="0.4 [m]", b="0.002 [N*m*s]", start=0.5235987755982988,
                              velocity=0.1, angle="rad", x="m")
# The same pendulum in grams, centimetres, degrees and millinewtons: it runs in SI inside.
PENDULUM_PREFIXED = PENDULUM.format(m="500 [g]", l="40 [cm]", b="2 [mN*m*s]", start=30, velocity="0.1/pi*180",
                                    angle="deg", x="cm")


def loaded(text: str, name: str = "units.lag"):
    return Model(SourceFile(name, text))


def test_prefixed_and_derived_units_are_converted_to_si():
    model = loaded(PENDULUM_PREFIXED).ir
    values = {p.name: p.value for p in model.parameters}
    assert values == pytest.approx({"m": 0.5, "l": 0.4, "g": 9.81, "b": 0.002}, rel=1e-15)
    theta, = model.coordinates
    assert float(theta.start) == pytest.approx(math.pi / 6, rel=1e-15)
    assert float(theta.velocity) == pytest.approx(0.1, rel=1e-15)
    assert model.units.unit_of("b") == "kg*m^2/s" and model.units.unit_of("theta") == "rad"


@pytest.mark.parametrize("degrees, radians", [(1, math.pi / 180), (30, math.pi / 6), (45, math.pi / 4),
                                              (90, math.pi / 2), (180, math.pi), (360, 2 * math.pi)])
def test_an_angle_in_degrees_is_its_radians_correctly_rounded(degrees, radians):
    """`30 [deg]` is the double nearest pi/6, not a 15-digit decimal of pi/180 times 30."""
    assert float(in_si(sympy.Integer(degrees), parse_unit(unit_span("[deg]")))) == radians


def test_prefixed_units_run_with_si_values_and_outputs_in_their_own_unit():
    si = loaded(PENDULUM_SI).simulate(backend="numpy")
    prefixed = loaded(PENDULUM_PREFIXED).simulate(backend="numpy")
    assert prefixed["theta"] == pytest.approx(si["theta"], rel=1e-10)
    assert prefixed["energy"] == pytest.approx(si["energy"], rel=1e-10)
    assert prefixed["x"] == pytest.approx(100 * si["x"], rel=1e-10)        # declared in cm


def test_scene_and_command_line_values_are_in_the_declared_unit():
    text = PENDULUM_PREFIXED.replace("    output theta, x, energy;", "    set l = 30;\n    set theta(start = 60);\n"
                                     "    output theta, x, energy;")
    model = loaded(text)
    plan = model.plan("swing")
    assert plan.parameters[1] == pytest.approx(0.3, rel=1e-15)
    assert plan.initial_state[0] == pytest.approx(math.pi / 3, rel=1e-15)
    overridden = model.plan("swing", Overrides(values=(("l", 25),)))
    assert overridden.parameters[1] == 0.25


def test_a_model_without_units_passes_silently(tmp_path):
    path = tmp_path / "plain.lag"
    path.write_text("model Plain\n  parameter k = 4;\n  coordinate x(start = 1);\n"
                    "  T = der(x)^2/2;\n  U = k/2*x^2 + 1 + cos(x*k);\nend Plain;\n")
    done = lagc_in_process("check", str(path))
    assert done.returncode == 0 and done.stderr == ""
    assert "[" not in done.stdout.split("parameters:")[1].splitlines()[0]
    assert load_model(path).units is None


def test_quantities_without_units_are_inferred_or_noted():
    model = model_from_source(SourceFile("units.lag", """model Spring
  parameter m = 2 [kg];
  parameter k = 4;
  parameter c = 1;
  parameter n = 3;
  parameter w = 1;
  coordinate x(start = 0.1) [m];
  coordinate y;
  T = m/2*der(x)^2 + w/2*der(y)^2;
  U = k/2*x^2 + c*x;
  force x = sum(k*x/n, i in 1:n);
end Spring;
"""))
    units = {name: (unit, inferred) for name, unit, inferred in model.units.quantities}
    assert units["k"] == ("kg/s^2", True) and units["c"] == ("N", True) and units["n"] == ("1", True)
    assert units["m"] == ("kg", False) and units["y"] == units["w"] == ("?", True)
    assert [(n.span.line, n.span.column) for n in model.units.notes] == [(6, 13), (8, 14)]
    note = model.units.notes[1]
    assert note.message == "the unit of 'y' could not be inferred, so what uses it was not checked; give it a unit"
    assert note.render().startswith("units.lag:8:14: note: ")


def test_inferred_dimensions_are_checked_where_they_are_used():
    with pytest.raises(LagError) as raised:
        model_from_source(SourceFile("units.lag", """model Spring
  parameter m = 2 [kg];
  parameter k = 4;
  coordinate x(start = 0.1) [m];
  T = m/2*der(x)^2;
  U = k/2*x^2;
  output wrong = k*x + m;
end Spring;
"""))
    diagnostic, = raised.value.diagnostics
    assert (diagnostic.span.line, diagnostic.span.column) == (7, 24)
    assert diagnostic.message == "'m' has dimension mass but 'k*x' has mass*length/time^2"


def test_every_library_model_carries_units_and_passes_the_check():
    for path in sorted(MODELS.glob("*.lag")):
        model = load_model(path)
        assert model.units is not None, path.name
        assert not model.units.notes, (path.name, [n.message for n in model.units.notes])
        assert "?" not in {unit for _, unit, _ in model.units.quantities}, path.name


@pytest.mark.slow
def test_run_units_names_the_units_in_the_csv_header(tmp_path):
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM_PREFIXED)
    command = ["run", str(path), "--backend", "numpy"]
    with_units = lagc_in_process(*command, "--units")
    assert with_units.stdout.splitlines()[0] == "t [s],theta [rad],x [cm],energy [J]"
    plain = lagc_in_process(*command)
    assert plain.stdout.splitlines()[0] == "t,theta,x,energy"
    assert with_units.stdout.splitlines()[1:] == plain.stdout.splitlines()[1:]


def test_check_shows_each_quantity_with_its_unit(tmp_path):
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM_PREFIXED)
    done = lagc_in_process("check", str(path))
    assert "  theta [deg] (= 0.0174532925199 rad)" in done.stdout        # as declared, SI beside
    assert ("parameters: m = 500 [g] (= 0.5 kg), l = 40 [cm] (= 0.4 m), g = 9.81 [m/s^2], "
            "b = 2 [mN*m*s] (= 0.002 kg*m^2/s)") in done.stdout
    assert "outputs: x [cm] (= 0.01 m)" in done.stdout


@pytest.mark.parametrize("unit, words, si", [
    ("[mJ]", "mass*length^2/time^2", "J"),
    ("[kN]", "mass*length/time^2", "N"),
    ("[m^(1/2)/s]", "length^(1/2)/time", "m^(1/2)/s"),
    ("[kg/(m*s^2)]", "mass/(length*time^2)", "kg/(m*s^2)"),
    ("[rpm]", "1/time", "1/s"),
    ("[deg]", "1", "1"),
])
def test_unit_dimensions_in_words_and_si(unit, words, si):
    parsed = dimension(parse_unit(unit_span(unit)))
    assert (parsed.words(), parsed.si()) == (words, si)


def test_the_solver_infers_unknowns_and_refuses_contradictions():
    solver = Solver()
    length, time = Form(Dimension.of(length=1)), Form(Dimension.of(time=1))
    assert solver.equate(Form.unknown("a") * Form.unknown("b"), length * length)   # a*b = m^2
    assert solver.equate(Form.unknown("a") / Form.unknown("b"), Form())             # a = b
    assert solver.resolve(Form.unknown("a")) == length
    assert not solver.equate(Form.unknown("b"), time)
    assert solver.equate(Form(wild=True), time)


# -- vectors, matrices, rigid bodies, parameter arrays and stop conditions -----------------------

TOP = """model Top "a heavy top written with the rigid-body functions"
  parameter I1 = 1.0 [kg*m^2];
  parameter I3 = 0.5 [kg*m^2];
  parameter m = 1 [kg];
  parameter l = 50 [cm];
  parameter g = 9.81 [m/s^2];
  coordinate phi(velocity = 0.5) [rad];
  coordinate theta(start = 0.6) [rad];
  coordinate psi(velocity = 20) [rad];
  let w = omega_zxz(phi, theta, psi);
  let I = diag(I1, I1, I3);
  let R = euler_zxz(phi, theta, psi);
  let r = R*{0, 0, l};
  T = 1/2*dot(w, I*w);
  U = m*g*r[3];
  output height = (transpose(R)*(rotz(phi)*{0, 0, l})).z [cm];
  output spin = omega_body(R).z + 0*w.x [1/s];
  scene short
    time(stop = 0.5);
    stop when r.z < l/2;
    output theta, height, spin, energy;
  end short;
end Top;
"""


def test_a_heavy_top_with_rigid_body_functions_passes_without_notes():
    model = loaded(TOP).ir
    assert not model.units.notes
    assert model.units.unit_of("spin") == "1/s" and model.units.unit_of("l") == "m"


CHAIN = """model Chain
  parameter n = 3;
  parameter m[n] = {1000, 2000, 3000} [g];
  parameter w2 = 4 [1/s^2];
  parameter k[n] = {m[i]*w2, i in 1:n} [N/m];
  parameter v0 = 1 [mm/s];
  coordinate x[n](start = {0.01*i, i in 1:n}, velocity = {v0*i, i in 1:n}) [m];
  T = sum(m[i]/2*der(x[i])^2, i in 1:n);
  U = sum(k[i]/2*x[i]^2, i in 1:n);
  scene s
    time(stop = 1, interval = 0.5);
    output x[1], x[3];
  end s;
end Chain;
"""


def test_parameter_arrays_in_grams_run_with_si_values():
    model = loaded(CHAIN)
    values = {p.name: p.value for p in model.ir.parameters}
    assert [values[f"m[{i}]"] for i in (1, 2, 3)] == pytest.approx([1, 2, 3], rel=1e-15)
    assert [values[f"k[{i}]"] for i in (1, 2, 3)] == pytest.approx([4, 8, 12], rel=1e-15)
    assert not model.ir.units.notes
    result = model.simulate(backend="numpy")
    # Each mass on its own spring, k_i/m_i = 4 /s^2: x_i(t) = 0.01 i cos(2 t) + 0.001 i/2 sin(2 t).
    t = result["t"]
    assert result["x[3]"] == pytest.approx(0.03 * np.cos(2 * t) + 0.0015 * np.sin(2 * t), abs=1e-7)


@pytest.mark.parametrize("text, old, new, line, column, message", [
    (TOP, "[kg*m^2]", "[kg*m]", 14, 7,
     "T has dimension mass*length/time^2 but U has mass*length^2/time^2"),
    (TOP, "let R = euler_zxz(phi, theta, psi);", "let R = euler_zxz(phi, theta, psi)*rotz(l);", 12, 43,
     "an angle of rotz() must be dimensionless, but 'l' has dimension length"),
    (TOP, "let I = diag(I1, I1, I3);", "let I = {{I1, l, 0}, {0, I1, 0}, {0, 0, I3}};", 14, 18,
     "the products summed in 'I*w' differ: mass*length^2/time and length/time"),
    (TOP, "omega_body(R).z", "omega_body(l*R).z", 17, 28,
     "the rotation matrix of omega_body() must be dimensionless, but it has length"),
    (TOP, "stop when r.z < l/2;", "stop when r.z < t;", 20, 21,
     "the sides of the stop condition differ: 't' has dimension time but 'r.z' has length"),
    (CHAIN, "{m[i]*w2, i in 1:n} [N/m]", "{m[i]*w2, i in 1:n} [N]", 5, 21,
     "the value of k has dimension mass/time^2 but its unit [N] has mass*length/time^2"),
    (CHAIN, "velocity = {v0*i, i in 1:n}", "velocity = {v0*w2, i in 1:n}", 7, 59,
     "the start velocity of x has dimension length/time^3 but der(x) has length/time"),
    (CHAIN, "parameter v0 = 1 [mm/s];", "parameter v0 = 1 [mm/s];\n  parameter a[n] = {0, w2, 0} [mm/s];", 7, 24,
     "the value of a has dimension 1/time^2 but its unit [mm/s] has length/time"),
])
def test_dimensional_mistakes_with_matrices_arrays_and_stop_conditions_are_located(text, old, new, line, column,
                                                                                  message):
    with pytest.raises(LagError) as raised:
        loaded(text.replace(old, new)).ir
    diagnostic = raised.value.diagnostics[0]          # (a wrong k makes U wrong too)
    assert diagnostic.message == message
    assert (diagnostic.span.line, diagnostic.span.column) == (line, column)


def test_a_value_with_its_unit_is_converted_as_the_declared_one_is():
    """`--set "theta.start=30 deg"` and simulate(set={"theta.start": "30 deg"}) run as the scene's
    own 30 [deg] does (bit for bit); "500g", "0.5 [kg]" and 0.5 set the same mass; a velocity
    takes the coordinate's unit per second."""
    model = loaded(PENDULUM_PREFIXED)
    scene = model.simulate(backend="numpy")
    for value in ("30 deg", "30deg", "30 [deg]"):
        run = model.simulate(backend="numpy", set={"theta.start": value})
        assert np.array_equal(run["theta"], scene["theta"]), value
    in_radians = model.simulate(backend="numpy", set={"theta.start": f"{math.pi / 6!r} rad"})
    assert in_radians["theta"] == pytest.approx(scene["theta"], rel=1e-12)
    masses = [model.simulate(backend="numpy", set={"m": value})["x"] for value in ("500g", "0.5 [kg]", 500)]
    assert np.array_equal(masses[0], masses[1]) and np.array_equal(masses[1], masses[2])
    turning = model.simulate(backend="numpy", set={"theta.velocity": "180 deg/s"}, stop=0.1)
    assert turning["theta"][0] == scene["theta"][0] and turning["theta"][1] > scene["theta"][1]
    assert model.plan(overrides=Overrides(values=(("theta.velocity", "1 rad/min"),))).initial_state[1] == \
        pytest.approx(1 / 60, rel=1e-15)


@pytest.mark.parametrize("name, value, words", [
    ("m", "500 m", "m: '500 m' is a length, but this value is declared in [g] (mass)"),
    ("theta.start", "30 m", "theta.start: '30 m' is a length, but this value is declared in [deg] (dimensionless)"),
    ("m", "500 blorp", "m: in '500 blorp': unknown unit 'blorp'"),
    ("m", "heavy", "m: expected a number, or a number and a unit such as '30 deg', got 'heavy'"),
    ("g", "9.81 m/s^2", None),
])
def test_a_value_with_a_unit_of_another_dimension_is_refused(name, value, words):
    model = loaded(PENDULUM_PREFIXED)
    if words is None:
        model.plan(overrides=Overrides(values=((name, value),)))
        return
    with pytest.raises(LagError) as refused:
        model.plan(overrides=Overrides(values=((name, value),)))
    assert words in str(refused.value)


def test_run_set_takes_a_unit(tmp_path):
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM_PREFIXED)
    command = ["run", str(path), "--backend", "numpy", "--stop", "0.2"]
    plain = lagc_in_process(*command)
    given = lagc_in_process(*command, "--set", "theta.start=30 deg", "--set", "m=500g")
    assert given.returncode == 0 and given.stdout == plain.stdout
    wrong = lagc_in_process(*command, "--set", "m=2 s")
    assert wrong.returncode == 1 and "lagc: error: m: '2 s' is a time, but this value is declared in [g]" in wrong.stderr


def test_a_sweep_refuses_a_value_with_a_unit_clearly(tmp_path):
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM_PREFIXED)
    done = lagc_in_process("sweep", str(path), "--backend", "numpy", "--set", "m=500g",
                           "--vary", "l=0.3:0.5:2", "-o", str(tmp_path / "out.csv"))
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "lagc: error: sweep: the values of 'm' are numbers, each in its declared unit; '500g'" in done.stderr


def test_times_take_a_unit_of_time(tmp_path):
    """--stop "200 ms" is --stop 0.2; simulate(stop="0.2 s", interval="50 ms") likewise; a length is refused."""
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM_PREFIXED)
    command = ["run", str(path), "--backend", "numpy", "--interval", "0.05"]
    seconds = lagc_in_process(*command, "--stop", "0.2")
    milliseconds = lagc_in_process(*command, "--stop", "200 ms")
    assert milliseconds.returncode == 0 and milliseconds.stdout == seconds.stdout
    wrong = lagc_in_process(*command, "--stop", "2 m")
    assert wrong.returncode == 1 and "lagc: error: --stop: '2 m' is a length, but this value is declared in [s]" \
        in wrong.stderr
    model = loaded(PENDULUM_PREFIXED)
    given = model.simulate(backend="numpy", stop="0.2 s", interval="50 ms")
    plain = model.simulate(backend="numpy", stop=0.2, interval=0.05)
    assert np.array_equal(given.t, plain.t) and np.array_equal(given["theta"], plain["theta"])


def test_the_table_of_common_unit_names_says_what_pint_says():
    """known_units.json spares a model of common units pint's import; pint stays the source:
    the file is what `python -m lagdsl.frontend.known_units` writes from it now."""
    from lagdsl.frontend import known_units
    assert known_units.TABLE.read_text(encoding="utf-8") == known_units.text(known_units.entries())
    assert {"m", "kg", "s", "N", "rad", "deg", "cm", "rpm"} <= set(known_units.entries())


def test_a_model_of_common_units_is_checked_without_pint():
    """The spring chain ([kg], [N/m], [m]) in a new process: pint is never imported."""
    program = ("import sys; from lagdsl.pipeline import load_model; "
               f"load_model({str(MODELS / 'spring_chain.lag')!r}); print('pint' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
