"""Every name a kernel block emits is an identifier of both targets (C99 and Python).

Regression: the Jacobian block of radau5 differentiates the equations again, and the
derivatives it names are intermediates the kernel's name table did not know when it was
built; they reached the printers as `∂δL/δr/∂r`.
"""
from __future__ import annotations

import pytest
import sympy

from lagdsl.codegen.c import FUNCTION_PARAMETERS
from lagdsl.codegen.kernel import Block, _Lowering, check_target_names, is_target_name, lower_to_kernel
from lagdsl.errors import InternalError
from lagdsl.pipeline import compile_model
from lagdsl.scene import Overrides, plan_scene
from lagdsl.source import SourceFile

PLANAR_ORBIT = """model P
  coordinate r(start = 1);
  coordinate phi(velocity = 1.2);
  T = der(r)^2/2 + r^2*der(phi)^2/2;
  U = -1/r;
end P;
"""


def lower(text: str, integrator: str):
    model, equations = compile_model(SourceFile("model.lag", text))
    return lower_to_kernel(equations, plan_scene(model, equations, None, Overrides(integrator=integrator)))


def emitted_names(block: Block) -> set[str]:
    """Every name the block declares or reads."""
    names = {name for name, _ in block.inputs} | {name for name, _ in block.assignments}
    expressions = [value for _, value in block.assignments] + [store.value for store in block.stores]
    return names | {symbol.name for value in expressions for symbol in value.free_symbols}


def assert_target_names(kernel) -> None:
    for kind in FUNCTION_PARAMETERS:
        block = getattr(kernel, kind)
        if block is not None:
            bad = sorted(name for name in emitted_names(block) if not is_target_name(name))
            assert not bad, f"{kind} block emits {bad}"


def test_radau5_jacobian_of_a_planar_orbit_uses_target_names():
    kernel = lower(PLANAR_ORBIT, "radau5")
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
