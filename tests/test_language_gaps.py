"""Vector components, lists given by their index, parameter arrays and rigid-body functions:
what they mean (front end) and the equations they give (against textbook forms)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import sympy

import lagdsl
from lagdsl.errors import LagError
from lagdsl.frontend.expressions import body_rates, rotation
from lagdsl.frontend.parser import parse
from lagdsl.frontend.semantics import build_model
from lagdsl.source import SourceFile
from tests.mechanics.eom import equations_from_text, is_zero, residual_rows, symbols_of
from tests.conftest import model_file


def model_of(text: str):
    source = SourceFile("test.lag", text)
    return build_model(parse(source), source)


def let_values(model) -> dict[str, sympy.Expr]:
    """Each let, with the lets it uses inlined."""
    values: dict[sympy.Symbol, sympy.Expr] = {}
    for let in model.lets:
        values[let.symbol] = let.expression.xreplace(values)
    return {let.name: values[let.symbol] for let in model.lets}


def error_of(text: str) -> str:
    with pytest.raises(LagError) as caught:
        model_of(text)
    return str(caught.value)


def assert_located(text: str, at: str, message: str) -> None:
    """The model is refused with `message`, located at the first occurrence of `at` in it."""
    offset = text.index(at)
    line = text.count("\n", 0, offset) + 1
    column = offset - (text.rfind("\n", 0, offset) + 1) + 1
    assert f"test.lag:{line}:{column}: error: {message}" in error_of(text)


# ---- components of vectors -------------------------------------------------------------------
def test_components_by_name_and_by_index_are_the_vector_entries():
    model = model_of("""model M
      coordinate x; coordinate y;
      let r = {x, 2*y, x*y};
      let by_name = r.x + 10*r.y + 100*r.z;
      let by_index = r[1] + 10*r[2] + 100*r[3];
      let of_call = cross(r, {0, 0, 1}).x;
      T = der(x)^2 + der(y)^2;
    end M;""")
    lets = let_values(model)
    x, y = (c.symbol for c in model.coordinates)
    assert sympy.expand(lets["by_name"] - (x + 20 * y + 100 * x * y)) == 0
    assert sympy.expand(lets["by_index"] - lets["by_name"]) == 0
    assert sympy.expand(lets["of_call"] - 2 * y) == 0


@pytest.mark.parametrize("body, at, message", [
    ("r.w", "w;", "a 3-vector has the components x, y and z, not 'w'"),
    ("x.z", "x.z", ".z takes a component of a 3-vector, but this is a scalar"),
    ("r[4]", "4]", "index 4 is out of range for a 3-vector (1:3)"),
    ("r[0]", "0]", "index 0 is out of range for a 3-vector (1:3)"),
    ("rotz(x).x", "rotz(x).x", ".x takes a component of a 3-vector, but this is a 3x3 matrix"),
])
def test_a_bad_component_is_located(body, at, message):
    assert_located(f"""model M
      coordinate x;
      let r = {{x, 0, 0}};
      let a = {body};
      T = der(x)^2;
    end M;""", at, message)


# ---- lists given by their index ----------------------------------------------------------------
def test_start_values_in_the_index_give_a_mode_shape():
    model = model_of("""model Chain
      parameter n = 4;
      parameter a = 0.1;
      coordinate q[n](start = {a*sin(pi*i/(n + 1)), i in 1:n}, velocity = {i^2, i in 1:n});
      T = sum(der(q[i])^2, i in 1:n);
    end Chain;""")
    defaults = {p.symbol: p.value for p in model.parameters}
    for i, c in enumerate(model.coordinates, 1):
        assert float(c.start.xreplace(defaults)) == pytest.approx(0.1 * np.sin(np.pi * i / 5), rel=1e-15)
        assert c.velocity == i**2


@pytest.mark.parametrize("declaration, at, message", [
    ("coordinate q[3](start = {i, i in 0:3});", "0:3",
     "the range 0:3 does not cover the members q[1] .. q[3]; write i in 1:3"),
    ("coordinate q[3](start = {1, 2, i in 1:3});", "{", "a list given by its index is written {expression, i in 1:n}"),
    ("coordinate q[3](start = {j, i in 1:3});", "j,", "undefined name 'j'"),
    ("coordinate q(start = {i, i in 1:3});", "{", "a list of initial values needs an indexed coordinate"),
    ("coordinate q; let b = {1, i in 1:3};", "{",
     "a list '{e, i in a:b}' gives the start values of an indexed coordinate"),
])
def test_bad_lists_are_located(declaration, at, message):
    assert_located(f"""model M
      {declaration}
      T = der(q)^2;
    end M;""".replace("der(q)", "der(q[1])" if "q[" in declaration else "der(q)"), at, message)


# ---- parameter arrays ----------------------------------------------------------------------------
ARRAY_MODEL = """model Springs "masses m[i] on springs of stiffness k"
  parameter n = 3;
  parameter m0 = 1 [kg];
  parameter m[n] = {m0*i, i in 1:n} [kg];
  parameter k[n] = {10, 20, 30} [N/m];
  parameter c[n] = 0.5;
  coordinate x[n](start = 1) [m];
  T = sum(m[i]/2*der(x[i])^2, i in 1:n);
  U = sum(k[i]/2*x[i]^2, i in 1:n);
  scene heavy
    time(stop = 1, interval = 0.5);
    set m[2] = 8;
    output x[2], m[2]*x[2];
  end heavy;
end Springs;
"""


def test_parameter_arrays_are_members_with_values_and_expressions():
    model = model_of(ARRAY_MODEL)
    values = {p.name: p.value for p in model.parameters}
    assert [values[f"m[{i}]"] for i in (1, 2, 3)] == [1, 2, 3]
    assert [values[f"k[{i}]"] for i in (1, 2, 3)] == [10, 20, 30]
    assert [values[f"c[{i}]"] for i in (1, 2, 3)] == [0.5] * 3
    assert next(p for p in model.parameters if p.name == "m[3]").unit.text == "kg"


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_parameter_arrays_in_sums_scenes_and_overrides(backend):
    model = lagdsl.load(model_file(ARRAY_MODEL, "springs"))
    # each x[i] is an oscillator of frequency sqrt(k[i]/m[i]); the scene sets m[2] = 8
    result = model.simulate("heavy", backend, rtol=1e-12, atol=1e-14)
    assert result.columns == ("x[2]", "m[2]*x[2]")
    assert result["x[2]"][-1] == pytest.approx(np.cos(np.sqrt(20 / 8)), abs=1e-9)
    assert result["m[2]*x[2]"][-1] == pytest.approx(8 * np.cos(np.sqrt(20 / 8)), abs=1e-8)
    # an override of one member, and a derived array that follows the parameter it is computed from
    assert model.simulate("heavy", backend, set={"m[2]": 5}, rtol=1e-12, atol=1e-14)["x[2]"][-1] == \
        pytest.approx(np.cos(2), abs=1e-9)
    plan = model.plan("heavy", lagdsl.scene.Overrides(values=(("m0", 2.0),)))
    values = dict(zip((p.name for p in model.ir.parameters), plan.parameters))
    assert (values["m[1]"], values["m[2]"], values["m[3]"]) == (2.0, 8.0, 6.0)


@pytest.mark.parametrize("declaration, at, message", [
    ("parameter m[3] = {1, 2};", "{",
     "2 values for the 3 parameters m[1] .. m[3]; give one value for all, or a list of 3"),
    ("parameter m[2.5] = 1;", "2.5", "the number of parameters must be an integer, not 2.5"),
    ("parameter m[2] = {1, y};", "y}", "undefined name 'y'"),
    ("parameter m[2] = 1; parameter p = m;", "m;", "'m' is an indexed family; write m[i]"),
    ("parameter m[2] = 1; parameter p = m[3];", "3]", "index 3 is out of range for 'm' (1:2)"),
])
def test_bad_parameter_arrays_are_located(declaration, at, message):
    assert_located(f"""model M
      {declaration}
      coordinate x;
      T = der(x)^2;
    end M;""", at, message)


def test_a_scene_sets_one_member_and_refuses_the_whole_array():
    assert_located(ARRAY_MODEL.replace("set m[2] = 8;", "set m = 8;"), "m = 8", "'m' is indexed; write set m[i] = ...")
    assert_located(ARRAY_MODEL.replace("set m[2] = 8;", "set m[4] = 8;"), "4]", "index 4 is out of range for 'm' (1:3)")


# ---- rigid bodies ----------------------------------------------------------------------------------
def test_rotations_are_proper_orthogonal_and_right_handed():
    a = sympy.Symbol("a", real=True)
    for axis in "xyz":
        R = sympy.Matrix(rotation(axis, a).rows)
        assert sympy.simplify(R.T * R - sympy.eye(3)) == sympy.zeros(3, 3)
        assert sympy.simplify(R.det()) == 1
    z = sympy.Matrix(rotation("z", a).rows)
    assert list(z * sympy.Matrix([1, 0, 0])) == [sympy.cos(a), sympy.sin(a), 0]


@pytest.mark.parametrize("convention", ["zxz", pytest.param("zyx", marks=pytest.mark.slow)])
def test_closed_form_body_rates_are_the_axial_vector_of_R_transpose_R_dot(convention):
    """omega_zxz/omega_zyx against omega_body(euler_...), i.e. R^T R' of the rotation itself."""
    model = model_of(f"""model Body
      coordinate a; coordinate b; coordinate c;
      let w = omega_{convention}(a, b, c);
      let v = omega_body(euler_{convention}(a, b, c));
      let s = omega_body(rot{convention[0]}(a)*rot{convention[1]}(b)*rot{convention[2]}(c));
      T = der(a)^2 + der(b)^2 + der(c)^2;
    end Body;""")
    lets = let_values(model)
    for axis in "xyz":
        assert sympy.trigsimp(sympy.expand(lets[f"w.{axis}"] - lets[f"v.{axis}"])) == 0
        assert sympy.expand(lets[f"s.{axis}"] - lets[f"v.{axis}"]) == 0


def test_body_rates_of_the_zxz_convention_are_goldsteins():
    phi, theta, psi, dphi, dtheta, dpsi = sympy.symbols("phi theta psi phi' theta' psi'", real=True)
    w = body_rates("zxz", (phi, theta, psi), (dphi, dtheta, dpsi)).components
    assert w[2] == dphi * sympy.cos(theta) + dpsi      # Goldstein (4.87)
    assert sympy.expand(w[0] - (dphi * sympy.sin(theta) * sympy.sin(psi) + dtheta * sympy.cos(psi))) == 0


HEAVY_TOP = """model HeavyTop "a symmetric top with a fixed point, z-x-z Euler angles"
  parameter M = 1 [kg];
  parameter l = 0.5 [m];
  parameter g = 9.81 [m/s^2];
  parameter I1 = 0.3 [kg*m^2];
  parameter I3 = 0.1 [kg*m^2];
  coordinate phi [rad];
  coordinate theta(start = 0.5) [rad];
  coordinate psi(velocity = 30) [rad];
  let R = euler_zxz(phi, theta, psi);
  let w = omega_zxz(phi, theta, psi);
  let I = diag(I1, I1, I3);
  T = 1/2*dot(w, I*w);
  U = M*g*(R*{0, 0, l}).z;
end HeavyTop;
"""


def test_the_heavy_top_has_the_textbook_equations():
    """L = I1/2 (theta'^2 + phi'^2 sin^2 theta) + I3/2 (psi' + phi' cos theta)^2 - M g l cos theta
    (Goldstein, 5.7): the Euler-Lagrange rows of the model are those of this L."""
    eq = equations_from_text(HEAVY_TOP)
    s = symbols_of(eq)
    phi, theta, psi = (s[n] for n in ("phi", "theta", "psi"))
    I1, I3, M, g, l = (s[n] for n in ("I1", "I3", "M", "g", "l"))
    t = sympy.Symbol("t")
    angles = [sympy.Function(n)(t) for n in ("phi", "theta", "psi")]
    p, th, ps = angles
    L = (I1 / 2 * (th.diff(t)**2 + p.diff(t)**2 * sympy.sin(th)**2)
         + I3 / 2 * (ps.diff(t) + p.diff(t) * sympy.cos(th))**2 - M * g * l * sympy.cos(th))
    plain = {}
    for f, q in zip(angles, (phi, theta, psi)):
        plain[f.diff(t, 2)] = s[q.name + "''"]
        plain[f.diff(t)] = s[q.name + "'"]
    for f, q in zip(angles, (phi, theta, psi)):
        plain[f] = q
    for row, f in zip(residual_rows(eq), angles):
        textbook = (L.diff(f.diff(t)).diff(t) - L.diff(f)).subs(plain)
        assert is_zero(row - textbook)


def test_the_free_asymmetric_body_keeps_energy_and_the_size_of_its_angular_momentum():
    path = model_file("""model FreeBody "a free asymmetric rigid body in z-x-z Euler angles"
      parameter I1 = 1 [kg*m^2];
      parameter I2 = 2 [kg*m^2];
      parameter I3 = 3 [kg*m^2];
      coordinate phi(velocity = 0.1) [rad];
      coordinate theta(start = 1, velocity = 0.2) [rad];
      coordinate psi(start = 0.3, velocity = 1) [rad];
      let I = {{I1, 0, 0}, {0, I2, 0}, {0, 0, I3}};
      let w = omega_zxz(phi, theta, psi);
      T = 1/2*dot(w, I*w);
      output spin = norm(I*w);
      scene tumble
        time(stop = 5, interval = 0.5);
        integrator dop853(rtol = 1e-12, atol = 1e-14);
        output spin, energy;
      end tumble;
    end FreeBody;""", "body")
    for backend in ("c", "numpy"):
        result = lagdsl.load(path).simulate("tumble", backend)
        assert np.ptp(result["spin"]) < 1e-9 * result["spin"][0]
        assert np.ptp(result["energy"]) < 1e-9 * result["energy"][0]


@pytest.mark.parametrize("body, at, message", [
    ("transpose(r)", "r)", "transpose() takes a 3x3 matrix, but this is a 3-vector"),
    ("r*rotz(x)", "r*", "a vector times a matrix is not defined; write transpose(A)*v"),
    ("rotx(r)", "r)", "rotx() takes scalars, but this is a 3-vector"),
    ("rotx(x) + r", "rotx(x) +", "cannot add a vector and a matrix"),
    ("norm(diag(1, 2, 3))", "diag", "norm() takes 3-vectors, but this is a 3x3 matrix"),
    ("{r, r, 1}", "r, r", "expected a scalar component, but this is a 3-vector"),
])
def test_matrix_mistakes_are_located(body, at, message):
    assert_located(f"""model M
      coordinate x;
      let r = {{x, 0, 0}};
      let a = {body};
      T = der(x)^2;
    end M;""", at, message)


@pytest.mark.slow
def test_one_member_is_set_from_the_command_line():
    path = model_file(ARRAY_MODEL, "springs")
    run = subprocess.run([sys.executable, "-m", "lagdsl", "run", str(path), "--set", "m[2]=5", "--rtol", "1e-12",
                          "--atol", "1e-14"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    header, *rows = run.stdout.splitlines()
    assert header == 't,x[2],m[2]*x[2]'
    assert float(rows[-1].split(",")[1]) == pytest.approx(np.cos(2), abs=1e-9)


def test_a_chain_started_in_a_mode_shape_stays_in_that_mode():
    """n masses between fixed walls: started in mode j, q[i](t) = a sin(pi i j/(n+1)) cos(w t),
    w = 2 sqrt(k/m) sin(pi j/(2(n+1)))."""
    path = model_file("""model Chain
      parameter n = 5;
      parameter j = 2;
      parameter k = 4 [N/m];
      parameter m[n] = 1 [kg];
      parameter a = 0.1 [m]         "amplitude";
      coordinate q[n](start = {a*sin(pi*i*j/(n + 1)), i in 1:n}) [m];
      T = sum(m[i]/2*der(q[i])^2, i in 1:n);
      U = k/2*(q[1]^2 + sum((q[i] - q[i - 1])^2, i in 2:n) + q[n]^2);
      scene mode
        time(stop = 3, interval = 0.5);
        integrator dop853(rtol = 1e-12, atol = 1e-14);
      end mode;
    end Chain;""", "chain")
    result = lagdsl.load(path).simulate("mode")
    w = 2 * np.sqrt(4) * np.sin(np.pi * 2 / 12)
    for i in range(1, 6):
        assert np.allclose(result[f"q[{i}]"], 0.1 * np.sin(np.pi * i * 2 / 6) * np.cos(w * result.t), atol=1e-10)
