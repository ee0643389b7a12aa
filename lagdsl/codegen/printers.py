"""Expression printers for the C and NumPy backends.

Both print the same scalar kernel expressions; symbols are renamed to target names
(`p_m1`, `q_theta1`, `c12`, ...) before printing, by the kernel's name table.
"""
from __future__ import annotations

from decimal import Decimal, localcontext

import sympy
from sympy.printing.c import C99CodePrinter
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import PRECEDENCE

from ..frontend.functions import PRINTED
PI_DIGITS = "3.14159265358979323846264338327950288"
E_DIGITS = "2.71828182845904523536028747135266250"
LARGEST_PLAIN_INTEGER = 2**31 - 1


def exact_decimal(value: sympy.Rational) -> str | None:
    """The exact decimal expansion of p/q when q = 2^a 5^b ("9.81", "6.674e-11"), else None."""
    q = int(value.q)
    while q % 2 == 0:
        q //= 2
    while q % 5 == 0:
        q //= 5
    if q != 1:
        return None
    with localcontext() as context:
        context.prec = 80
        exact = Decimal(int(value.p)) / Decimal(int(value.q))
    if exact != 0 and not Decimal("1e-4") <= abs(exact) < Decimal("1e16"):
        mantissa, exponent = format(exact, "e").split("e")
        mantissa = mantissa.rstrip("0").rstrip(".") if "." in mantissa else mantissa
        return f"{mantissa}e{int(exponent)}"
    text = format(exact, "f")
    text = text.rstrip("0") if "." in text else text + "."
    return text + "0" if text.endswith(".") else text


def significant_digits(value: sympy.Rational, digits: int = 36) -> str:
    """p/q rounded to `digits` significant digits in exponent notation ("1.234...e-5")."""
    with localcontext() as context:
        context.prec = digits
        return format(Decimal(int(value.p)) / Decimal(int(value.q)), "e")


def is_dyadic(value: sympy.Rational) -> bool:
    q = int(value.q)
    return q & (q - 1) == 0


class CPrinter(C99CodePrinter):
    """C99 printer for lagdsl kernels, generic in the floating-point type `real`.

    Number policy: integers print as C integers (products with `real` promote exactly);
    a rational with a power-of-two denominator prints as its exact decimal (0.5); any other
    terminating decimal prints as LAG_LIT(9.81), which the runtime turns into 9.81, 9.81L or
    9.81Q, so long double and __float128 builds get the constant to their own precision;
    other rationals print as (LAG_LIT(1.0)/3) when numerator and denominator are exact C
    integers, else (a sum of 330 fractions has 140-digit ones) as LAG_LIT with 36 significant
    digits. pi and e print as LAG_LIT with 36 digits, enough for __float128.

    Functions go through the runtime's table (r_sin, r_sqrt, ...), never libm names directly: the
    built-in functions print as the `c` names of their records (functions.py).

    Powers: integer powers 2 to 4 of a symbol print as parenthesized products ((x*x)), since kernels are
    built without -ffast-math; negative ones as 1/(x*x); square roots as r_sqrt; other powers
    call r_pow (gcc folds r_pow(x, 2) of an expression into a product by itself).
    """

    def __init__(self, settings=None):
        super().__init__(settings or {})

    def _print_Integer(self, expr):
        if abs(int(expr)) > LARGEST_PLAIN_INTEGER:
            return f"LAG_LIT({int(expr)}.0)"
        return str(int(expr))

    def _print_Rational(self, expr):
        decimal = exact_decimal(expr)
        if decimal is not None:
            return decimal if is_dyadic(expr) else f"LAG_LIT({decimal})"
        if max(abs(int(expr.p)), int(expr.q)) > LARGEST_PLAIN_INTEGER:
            return f"LAG_LIT({significant_digits(expr)})"
        return f"(LAG_LIT({int(expr.p)}.0)/{int(expr.q)})"

    def _print_Float(self, expr):
        return f"LAG_LIT({repr(float(expr))})"

    def _print_Mul(self, expr):
        # A positive rational coefficient reads best in front: LAG_LIT(9.81)*x, 0.5*m*v*v.
        coefficient, rest = expr.as_coeff_Mul()
        if coefficient.is_Rational and not coefficient.is_Integer and coefficient > 0 and rest != 1:
            return f"{self._print(coefficient)}*{self._print(rest) if rest.is_Mul else self.parenthesize(rest, PRECEDENCE['Mul'])}"
        return super()._print_Mul(expr)

    def _print_Pi(self, expr):
        return f"LAG_LIT({PI_DIGITS})"

    def _print_Exp1(self, expr):
        return f"LAG_LIT({E_DIGITS})"

    def _print_Pow(self, expr):
        base, exponent = expr.args
        if exponent == sympy.S.Half:
            return f"r_sqrt({self._print(base)})"
        if exponent == -sympy.S.Half:
            return f"(1.0/r_sqrt({self._print(base)}))"
        if exponent.is_Integer and base.is_Symbol and 2 <= abs(int(exponent)) <= 4:
            # Parenthesized: the Mul printer puts powers after '/' without parentheses.
            product = "*".join([self._print(base)] * abs(int(exponent)))
            return f"({product})" if exponent > 0 else f"(1.0/({product}))"
        if exponent == -1:
            return f"(1.0/{self.parenthesize(base, PRECEDENCE['Mul'] + 1)})"
        return f"r_pow({self._print(base)}, {self._print(exponent)})"

    def _print_sign(self, expr):
        x = self._print(expr.args[0])
        return f"((real)(({x} > 0) - ({x} < 0)))"

    def _print_Heaviside(self, expr):
        return f"((real)({self._print(expr.args[0])} > 0))"

    def _print_DiracDelta(self, expr):
        return "0"


def _call(function: str):
    """f(x), f(x, y); a min or max of more arguments (sympy flattens them) as nested pairs."""
    def printer(self, expr):
        text = self._print(expr.args[0])
        if len(expr.args) == 1:
            return f"{function}({text})"
        for arg in expr.args[1:]:
            text = f"{function}({text}, {self._print(arg)})"
        return text
    return printer


class TaylorPrinter(CPrinter):
    """The C printer of taylor's series: sin and cos are the series' own lag_sin and lag_cos
    (integrators/c/taylor_functions.c), plain arithmetic that the sweep's lanes vectorise with the
    same results as simulate()'s series."""

    _print_sin = _call("lag_sin")
    _print_cos = _call("lag_cos")


class PythonPrinter(NumPyPrinter):
    """NumPy printer: the same kernels as Python over arrays (a batch of states broadcasts).

    Numbers print as Python floats or exact fractions (981/100 is correctly rounded by
    Python's division); functions are numpy's (the `numpy` names of their records in
    functions.py); min and max are elementwise.
    """

    def __init__(self, settings=None):
        super().__init__({"fully_qualified_modules": True, **(settings or {})})

    def _print_Heaviside(self, expr):
        return f"numpy.heaviside({self._print(expr.args[0])}, 0.0)"

    def _print_DiracDelta(self, expr):
        return "0.0"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) > LARGEST_PLAIN_INTEGER else str(int(expr))


for _function in PRINTED:
    if _function.c is not None:
        setattr(CPrinter, f"_print_{_function.value.__name__}", _call(f"r_{_function.c}"))
    setattr(PythonPrinter, f"_print_{_function.value.__name__}", _call(_function.numpy))
