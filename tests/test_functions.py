"""The table of built-in functions (functions.py) is what the language, the printers and the C
runtime read: each record's function is callable in a model with its arity, prints under its
C and NumPy names, and has its libm name defined in the runtime."""
from __future__ import annotations

import pytest
import sympy

from lagdsl.codegen.c_abi import runtime_header
from lagdsl.codegen.printers import CPrinter, PythonPrinter
from lagdsl.errors import LagError
from lagdsl.frontend.functions import BUILTINS, LIBM_TABLE_MARKER, PRINTED, TABLE
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile

X, Y = sympy.symbols("x y", real=True)
# The functions of scalars to scalars: those with a libm function, and sign.
SCALAR_FUNCTIONS = sorted(name for name, f in BUILTINS.items() if f.c is not None or f in PRINTED)


def output_of(call: str):
    """The value of `output y = <call>;` in a one-coordinate model."""
    text = f"model M\n  coordinate x(start = 0.5);\n  T = der(x)^2/2;\n  output y = {call};\nend M;\n"
    return model_from_source(SourceFile("m.lag", text)).outputs[0].expression


def test_the_runtime_defines_the_libm_function_of_every_record_in_table_order():
    header = runtime_header()
    assert LIBM_TABLE_MARKER not in header
    defined = [line.split()[1] for line in header.splitlines() if line.startswith("#define r_") and "LAG_FN(" in line]
    assert defined == [f"r_{f.c}" for f in TABLE if f.c is not None]


@pytest.mark.parametrize("function", PRINTED, ids=lambda f: f.name)
def test_each_function_prints_under_its_c_and_numpy_names(function):
    value = function.value(*(X, Y)[:function.arity])
    python = PythonPrinter().doprint(value)
    assert python.startswith(f"{function.numpy}(")
    c = CPrinter().doprint(value)
    if function.c is not None:
        assert c.startswith(f"r_{function.c}(")
    else:
        assert "r_" not in c                # sign: a comparison, no libm call


@pytest.mark.parametrize("name", SCALAR_FUNCTIONS)
def test_each_scalar_function_is_called_with_its_arity_and_builds_its_value(name):
    function = BUILTINS[name]
    arguments = ", ".join(["x"] * function.arity)
    assert output_of(f"{name}({arguments})") == function.value(*[sympy.Symbol("x", real=True)] * function.arity)
    with pytest.raises(LagError) as raised:
        output_of(f"{name}({arguments}, x)")
    plural = "s" if function.arity != 1 else ""
    assert raised.value.diagnostics[0].message == f"{name}() takes {function.arity} argument{plural}, got {function.arity + 1}"
