"""The printers' number, power and function policies, pinned as exact strings."""
import sympy

from lagdsl.codegen.printers import CPrinter, PythonPrinter, exact_decimal

x, y = sympy.symbols("x y", real=True)


def c(expr) -> str:
    return CPrinter().doprint(expr)


def test_numbers_are_exact_in_every_precision():
    assert c(sympy.Rational(981, 100) * x) == "LAG_LIT(9.81)*x"
    assert c(sympy.Rational(1, 2) * x * y) == "0.5*x*y"
    assert c(sympy.Rational(1, 3) + x) == "x + (LAG_LIT(1.0)/3)"
    assert c(sympy.Integer(2) * x) == "2*x"
    assert c(sympy.Integer(10)**12 * x) == "LAG_LIT(1000000000000.0)*x"
    assert c(sympy.pi * x).startswith("LAG_LIT(3.14159265358979323846")
    assert exact_decimal(sympy.Rational(6674, 10**14)) == "6.674e-11"


def test_rationals_beyond_c_integers_print_as_36_digit_literals():
    # The sum 1 + 1/2 + ... + 1/330 has a 140-digit denominator: not a C integer constant.
    harmonic = sympy.harmonic(330)
    assert c(harmonic) == "LAG_LIT(6.37782270564987502558997278415261367e+0)"
    assert c(sympy.Rational(2**40, 3)) == "LAG_LIT(3.66503875925333333333333333333333333e+11)"
    assert c(sympy.Rational(2**31 - 1, 3)) == "(LAG_LIT(2147483647.0)/3)"


def test_powers():
    assert c(x**2) == "(x*x)"
    assert c(x**4) == "(x*x*x*x)"
    assert c(y / x**2) == "y/(x*x)"          # not y/x*x
    assert c(x**-2) == "(1.0/(x*x))"
    assert c(x**-1) == "(1.0/x)"
    assert c(sympy.sqrt(x)) == "r_sqrt(x)"
    assert c(1 / sympy.sqrt(x)) == "(1.0/r_sqrt(x))"
    assert c((x + y)**2) == "r_pow(x + y, 2)"
    assert c(x**5) == "r_pow(x, 5)"


def test_functions_go_through_the_precision_table():
    assert c(sympy.sin(x) + sympy.exp(y)) == "r_exp(y) + r_sin(x)"
    assert c(sympy.atan2(y, x)) == "r_atan2(y, x)"
    assert c(sympy.Abs(x)) == "r_fabs(x)"
    assert c(sympy.Max(x, y)) == "r_fmax(x, y)"
    assert c(sympy.sign(x)) == "((real)((x > 0) - (x < 0)))"


def test_python_printer():
    p = PythonPrinter()
    assert p.doprint(sympy.sin(x) * sympy.Rational(981, 100)) == "(981/100)*numpy.sin(x)"
    assert p.doprint(sympy.Max(x, y)) == "numpy.maximum(x, y)"
