"""Every name a kernel block emits is an identifier of both targets (C99 and Python).

Regression: the Jacobian block of radau5 differentiates the equations again, and the
derivatives it names are intermediates the kernel's name table did not know when it was
built; they reached the printers as `∂δL/δr/∂r`. The property test lowers generated models
(lets, nested lets, constraints of both kinds, forces, dissipation, explicit time, derived
parameters, names that are keywords of C or Python) for every integrator they admit and
checks every block; a few of them are compiled with the strict flags.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import pytest
import sympy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lagdsl.integrators import registry
from lagdsl.codegen.c import FUNCTION_PARAMETERS, render_c
from lagdsl.codegen.kernel import Block, Kernel, _Lowering, lower_to_kernel
from lagdsl.codegen.naming import check_target_names, is_target_name
from lagdsl.codegen.numpy import render_numpy
from lagdsl.errors import InternalError, LagError
from lagdsl.pipeline import compile_model
from lagdsl.run.toolchain import STRICT_FLAGS, find_compiler
from lagdsl.scene import Overrides, plan_scene
from lagdsl.source import SourceFile
from tests.conftest import compiled, examples

PLANAR_ORBIT = """model P
  coordinate r(start = 1);
  coordinate phi(velocity = 1.2);
  T = der(r)^2/2 + r^2*der(phi)^2/2;
  U = -1/r;
end P;
"""
# Model names that are keywords or look like the kernel's own names (q_, let_, der_, w0, c0).
NAMES = ["x", "theta", "double", "int", "lambda", "None", "while", "w0", "c0", "der_x", "q_x", "let_y",
         "restrict", "r"]


def kernels(text: str, integrators=registry.names()) -> dict[str, Kernel]:
    """The model lowered for each integrator it admits (fixed-step ones with a step of 0.01). The
    blocks depend on the integrator's kind alone (with a Jacobian or not, canonical or not: the
    plan's `implicit` and `canonical`), so each kind is lowered once and the kernels of its other
    integrators differ from that one in their `integrator` field only (as lowering each does)."""
    model, equations = compile_model(SourceFile("model.lag", text))
    lowered, of_kind = {}, {}
    for integrator in integrators:
        if integrator == "gauss" and equations.active_constraints:
            continue
        if integrator == "rkn8" and (equations.active_constraints or equations.velocity_in_accelerations):
            continue
        options = (("step", 0.01),) if integrator in ("rk4", "gauss") else ()
        plan = plan_scene(model, equations, None, Overrides(integrator=integrator, options=options))
        kind = (plan.implicit, plan.canonical)
        if kind not in of_kind:
            of_kind[kind] = lower_to_kernel(equations, plan)
        lowered[integrator] = dataclasses.replace(of_kind[kind], integrator=plan.integrator)
    return lowered


def emitted_names(block: Block) -> set[str]:
    """Every name the block declares or reads."""
    names = {name for name, _ in block.inputs} | {name for name, _ in block.assignments}
    expressions = [value for _, value in block.assignments] + [store.value for store in block.stores]
    return names | {symbol.name for value in expressions for symbol in value.free_symbols}


def assert_target_names(kernel: Kernel) -> None:
    for kind in FUNCTION_PARAMETERS:
        block = getattr(kernel, kind)
        if block is not None:
            bad = sorted(name for name in emitted_names(block) if not is_target_name(name))
            assert not bad, f"{kind} block emits {bad}"


# -- generated models ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Features:
    coordinates: tuple[str, str, str]
    lets: bool = False                  # positions as lets of the coordinates
    nested: bool = False                # a let of lets
    holonomic: bool = False
    rheonomic: bool = False             # the holonomic constraint depends on t
    nonholonomic: bool = False
    force: bool = False
    dissipation: bool = False
    time_in_potential: bool = False
    time_in_kinetic: bool = False       # a moving support: T depends on t through a let
    derived_parameter: bool = False

    def text(self) -> str:
        a, b, c = self.coordinates
        lines = ["model Generated",
                 "  parameter m = 1.5;",
                 "  parameter k = 2.0;",
                 "  parameter omega = 3.0;",
                 "  parameter I = m*k/2;" if self.derived_parameter else "  parameter I = 0.75;",
                 f"  coordinate {a}(start = 0.3, velocity = 0.1);",
                 f"  coordinate {b}(start = 0.2);",
                 f"  coordinate {c}(start = 0.1, velocity = -0.2);"]
        support = " + k/10*cos(omega*t)" if self.time_in_kinetic else ""
        if self.lets:
            lines += [f"  let px = k*sin({a}) + {b};", f"  let py = -k*cos({a}){support};"]
            if self.nested:
                lines.append(f"  let pz = px*cos({c}) + py*sin({b});")
            kinetic = "m/2*(der(px)^2 + der(py)^2)" + (" + m/4*der(pz)^2" if self.nested else "")
            potential = "m*9.81*py"
        else:
            kinetic = f"m/2*(der({a})^2 + der({b}{support})^2)"
            potential = f"k/2*({a}^2 + {b}^2)"
        kinetic += f" + m/2*der({a})^2 + m/2*der({b})^2 + I/2*der({c})^2 + m/3*{a}*der({b})*der({c})"
        if self.time_in_potential:
            potential += f" + k*{c}*sin(omega*t)"
        lines += [f"  T = {kinetic};", f"  U = {potential} + k/2*{c}^2;"]
        if self.holonomic:
            drive = "k/10*sin(omega*t)" if self.rheonomic else "0.25"
            lines.append(f"  constraint hold: sin({a}) + {b} = {drive};")
        if self.nonholonomic:
            lines.append(f"  constraint roll: der({c}) + {a}*der({b}) = 0;")
        if self.force:
            lines.append(f"  force {a} = -k*der({a}) + cos(omega*t);")
        if self.dissipation:
            lines.append(f"  dissipation = k/2*der({b})^2 + m/2*{a}^2*der({c})^2;")
        lines.append("end Generated;")
        return "\n".join(lines) + "\n"


@st.composite
def features(draw) -> Features:
    coordinates = tuple(draw(st.lists(st.sampled_from(NAMES), min_size=3, max_size=3, unique=True)))
    flags = {name: draw(st.booleans()) for name in
             ("lets", "nested", "holonomic", "rheonomic", "nonholonomic", "force", "dissipation",
              "time_in_potential", "time_in_kinetic", "derived_parameter")}
    return Features(coordinates, **flags)


@pytest.mark.slow
@settings(max_examples=examples(40), deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(features())
def test_generated_models_emit_only_target_names_in_every_block(model):
    for integrator, kernel in kernels(model.text()).items():
        assert_target_names(kernel)
        if integrator == "radau5":
            assert kernel.jacobian is not None
        compile(render_numpy(kernel).text, f"{integrator}.py", "exec")    # a SyntaxError fails here


EVERYTHING = Features(("double", "lambda", "w0"), lets=True, nested=True, holonomic=True, rheonomic=True,
                      nonholonomic=True, force=True, dissipation=True, time_in_potential=True,
                      time_in_kinetic=True, derived_parameter=True)
COMPILED = [
    pytest.param(EVERYTHING, "radau5", id="everything-radau5"),
    pytest.param(Features(("x", "theta", "r"), holonomic=True, rheonomic=True), "radau5", id="rheonomic-radau5"),
    pytest.param(Features(("c0", "q_x", "int"), lets=True, nested=True, nonholonomic=True, dissipation=True),
                 "radau5", id="nonholonomic-radau5"),
    pytest.param(Features(("theta", "der_x", "None"), lets=True, nested=True, time_in_kinetic=True, force=True,
                          derived_parameter=True), "gauss", id="lets-gauss"),
]


@pytest.mark.parametrize("model, integrator", COMPILED)
def test_generated_c_compiles_with_strict_flags(model, integrator, tmp_path):
    try:
        find_compiler()
    except LagError:
        pytest.skip("no C compiler")
    kernel = kernels(model.text(), (integrator,))[integrator]
    source = tmp_path / "model.c"
    source.write_text(render_c(kernel).text, encoding="utf-8")
    done = compiled([find_compiler(), *STRICT_FLAGS, source, "-o", tmp_path / "model", "-lm"])
    assert done.returncode == 0, done.stderr


# -- the planar orbit of the bug report and the checks themselves --------------------------------
def test_radau5_jacobian_of_a_planar_orbit_uses_target_names():
    kernel = kernels(PLANAR_ORBIT, ("radau5",))["radau5"]
    assert kernel.jacobian is not None
    assert_target_names(kernel)


@pytest.mark.parametrize("name", ["x", "abc_12", "_y", "q_theta1"])
def test_identifiers_are_target_names(name):
    assert is_target_name(name)


@pytest.mark.parametrize("name", ["∂x/∂q", "δL", "1x", "x y", "", "double", "while", "lambda", "None",
                                  "restrict", "_Bool", "der(x)"])
def test_non_identifiers_and_keywords_are_not_target_names(name):
    assert not is_target_name(name)


def test_a_symbol_outside_the_name_table_is_an_internal_error():
    model, equations = compile_model(SourceFile("model.lag", PLANAR_ORBIT))
    lowering = _Lowering(equations, plan_scene(model, equations, None, Overrides()))
    stray = sympy.Symbol("stray", real=True)
    with pytest.raises(InternalError, match="unbound symbol stray"):
        lowering.block([("b", (0,), stray)])


def test_an_invalid_or_shared_name_is_an_internal_error():
    x, y = sympy.symbols("x y", real=True)
    with pytest.raises(InternalError, match="not a C and Python identifier"):
        check_target_names({x: sympy.Symbol("∂x/∂q")})
    with pytest.raises(InternalError, match="stands for both"):
        check_target_names({x: sympy.Symbol("w1"), y: sympy.Symbol("w1")})
