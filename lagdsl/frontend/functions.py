"""The built-in functions of the language, one record each: what a call needs and builds, its
dimension, and how generated C and NumPy code call it.

Every stage reads this table: the expression builder (arity, arguments, value), the dimension
check (`dimension`, a rule over the dimensions of the arguments, dimensions.py), the printers
(codegen/printers.py: `r_<c>` in C, `numpy` in Python) and the C runtime, whose libm table
(`#define r_sin LAG_FN(sin)`, which is sin, sinl or sinq by precision) is generated from the `c`
names in the order of the table (`libm_table`, pasted into runtime.h by codegen/c.py). Adding a
function is one record.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

import sympy

from .dimensions import ENERGY, POWER, TIME, Form, components, is_matrix, map_forms
from .values import Matrix, Vector, body_rates, dot, matrix_product, rotation

# runtime.h holds this line where the libm table goes (codegen/c.py pastes `libm_table()` there).
LIBM_TABLE_MARKER = "/* LIBM_TABLE: generated from lagdsl/frontend/functions.py, pasted here by codegen/c.py */\n"


@dataclass(frozen=True)
class Builtin:
    """A function a model calls by name.

    `kind` is "function" (its arguments are built, checked against `takes` and given to `value`),
    "special" (der and sum: the builder reads their arguments itself) or "observable" (momentum,
    multiplier, residual: values of the solved motion, for outputs only).
    """

    name: str
    arity: int
    kind: str
    dimension: Callable             # (DimensionCheck, call node, argument nodes) -> the call's dimension
    takes: str = "scalars"          # "scalars", "3-vectors" or "a 3x3 matrix": what each argument must be
    value: Callable | None = None   # the arguments' values (then their time derivatives) -> the value
    rates: bool = False             # value() also takes the arguments' time derivatives
    c: str | None = None            # the libm function of runtime.h's r_<c>
    numpy: str | None = None        # the function the NumPy backend prints


@dataclass(frozen=True)
class LibmFunction:
    """A function of runtime.h's libm table that no model calls by name: r_pow prints a^b, and
    r_floor serves the integrators and the standalone program."""

    c: str


# -- dimension rules: (check, call, arguments) -> dimension (docs/language.md, "Units") ---------
def _plain_argument(check, call, arguments) -> Form:
    check.dimensionless(arguments[0], f"the argument of {call.children[0]}()")
    return Form()


def _plain(check, call, arguments) -> Form:
    return Form()


def _root(check, call, arguments) -> Form:
    return check.scalar(arguments[0]) ** Fraction(1, 2)


def _same(check, call, arguments):
    return check.scalar(arguments[0])


def _alike(check, call, arguments) -> Form:
    """min, max, atan2: both arguments of one dimension (atan2 is then an angle)."""
    first, second = (check.scalar(a) for a in arguments)
    check.differ(second, arguments[1], first, arguments[0], "the second argument", "the first argument")
    return Form() if str(call.children[0]) == "atan2" else first


def _rate(check, call, arguments):
    return map_forms(check.form(arguments[0]), lambda c: c / Form(TIME))


def _summed(check, call, arguments):
    return check.built_form(arguments[0])


def _vector_function(check, call, arguments):
    """dot, cross, norm of vectors whose components share a dimension."""
    shared = [check.common(check.form(a), a) for a in arguments]
    name = str(call.children[0])
    if name == "norm":
        return shared[0]
    product = shared[0] * shared[1]
    return product if name == "dot" else (product, product, product)


def _diagonal(check, call, arguments):
    values = [check.scalar(a) for a in arguments]
    return tuple(tuple(values[i] if i == j else Form(wild=True) for j in range(3)) for i in range(3))


def _transposed(check, call, arguments):
    value = check.form(arguments[0])
    return tuple(zip(*value)) if is_matrix(value) else value


def _rotation(check, call, arguments):
    """rotx .. euler_zyx: a dimensionless matrix of angles."""
    for argument in arguments:
        check.dimensionless(argument, f"an angle of {call.children[0]}()")
    return ((Form(),) * 3,) * 3


def _angular_velocity(check, call, arguments):
    """omega_zxz, omega_zyx of three angles: 1/time."""
    for argument in arguments:
        check.dimensionless(argument, f"an angle of {call.children[0]}()")
    return (Form(TIME) ** -1,) * 3


def _body_angular_velocity(check, call, arguments):
    """omega_body of a (dimensionless) rotation matrix: 1/time."""
    check.require_each(((entry, Form()) for entry in components(check.form(arguments[0]))), arguments[0],
                       lambda entry, _: "the rotation matrix of omega_body() must be dimensionless, but it has "
                                        f"{check.words(entry)}")
    return (Form(TIME) ** -1,) * 3


def _multiplier(check, call, arguments) -> Form:
    """λ of constraint c: Aᵀλ is a generalized force, A = ∂c/∂q (holonomic) or ∂c/∂q'."""
    value, holonomic = check.constraint_dimension(arguments[0])
    return Form(ENERGY) / value if holonomic else Form(POWER) / value


def _momentum(check, call, arguments) -> Form:
    """p = ∂L/∂q': an energy times a time divided by q's dimension."""
    return Form(ENERGY * TIME) / check.scalar(arguments[0])


def _residual(check, call, arguments) -> Form:
    return check.constraint_dimension(arguments[0])[0]


# -- values: the arguments' values (then their time derivatives) -> the value ----------------
def _dot_product(a: Vector, b: Vector) -> sympy.Expr:
    return sum(x * y for x, y in zip(a.components, b.components))


def _cross_product(a: Vector, b: Vector) -> Vector:
    a, b = a.components, b.components
    return Vector((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))


def _norm_of(a: Vector) -> sympy.Expr:
    return sympy.sqrt(sum(c**2 for c in a.components))


def _diagonal_matrix(*entries) -> Matrix:
    return Matrix(tuple(tuple(entries[i] if i == j else sympy.S.Zero for j in range(3)) for i in range(3)))


def _transpose_of(a: Matrix) -> Matrix:
    return Matrix(tuple(a.column(j) for j in range(3)))


def _rotation_about(axis: str) -> Callable:
    return lambda angle: rotation(axis, angle)


def _euler(axes: str) -> Callable:
    """R = rot<axes[0]>(a) rot<axes[1]>(b) rot<axes[2]>(c), body to space."""
    def matrix(*angles):
        first, second, third = (rotation(axis, angle) for axis, angle in zip(axes, angles))
        return matrix_product(matrix_product(first, second), third)
    return matrix


def _euler_rates(convention: str) -> Callable:
    """The angular velocity in body axes from three Euler angles and their rates."""
    return lambda *angles_and_rates: body_rates(convention, angles_and_rates[:3], angles_and_rates[3:])


def _velocity_in_body(matrix: Matrix, rate: Matrix) -> Vector:
    """The angular velocity in the body frame of the rotation R (body to space): the axial vector
    of the skew matrix R^T R'."""
    skew = [[dot(matrix.column(i), rate.column(j)) for j in range(3)] for i in range(3)]
    return Vector((skew[2][1], skew[0][2], skew[1][0]))


def _scalar(name: str, arity: int, value, dimension, c: str | None, numpy: str) -> Builtin:
    return Builtin(name, arity, "function", dimension, value=value, c=c, numpy=numpy)


def _plain_function(name: str, value, numpy: str) -> Builtin:
    """sin, cos, exp, ...: a function of a dimensionless argument, r_<name> in C."""
    return _scalar(name, 1, value, _plain_argument, name, numpy)


# In the order of runtime.h's libm table (r_sqrt first), then the functions without a C name.
TABLE = (
    _scalar("sqrt", 1, sympy.sqrt, _root, "sqrt", "numpy.sqrt"),
    _scalar("abs", 1, sympy.Abs, _same, "fabs", "abs"),
    LibmFunction("pow"),
    _plain_function("exp", sympy.exp, "numpy.exp"),
    _plain_function("log", sympy.log, "numpy.log"),
    _plain_function("sin", sympy.sin, "numpy.sin"),
    _plain_function("cos", sympy.cos, "numpy.cos"),
    _plain_function("tan", sympy.tan, "numpy.tan"),
    _plain_function("asin", sympy.asin, "numpy.arcsin"),
    _plain_function("acos", sympy.acos, "numpy.arccos"),
    _plain_function("atan", sympy.atan, "numpy.arctan"),
    _scalar("atan2", 2, sympy.atan2, _alike, "atan2", "numpy.arctan2"),
    _plain_function("sinh", sympy.sinh, "numpy.sinh"),
    _plain_function("cosh", sympy.cosh, "numpy.cosh"),
    _plain_function("tanh", sympy.tanh, "numpy.tanh"),
    _scalar("min", 2, sympy.Min, _alike, "fmin", "numpy.minimum"),
    _scalar("max", 2, sympy.Max, _alike, "fmax", "numpy.maximum"),
    LibmFunction("floor"),
    _scalar("sign", 1, sympy.sign, _plain, None, "numpy.sign"),     # C: ((x > 0) - (x < 0)), printers.py
    # vectors, matrices, rotations and rigid bodies (docs/language.md, "Rigid bodies")
    Builtin("dot", 2, "function", _vector_function, "3-vectors", _dot_product),
    Builtin("cross", 2, "function", _vector_function, "3-vectors", _cross_product),
    Builtin("norm", 1, "function", _vector_function, "3-vectors", _norm_of),
    Builtin("rotx", 1, "function", _rotation, value=_rotation_about("x")),
    Builtin("roty", 1, "function", _rotation, value=_rotation_about("y")),
    Builtin("rotz", 1, "function", _rotation, value=_rotation_about("z")),
    Builtin("diag", 3, "function", _diagonal, value=_diagonal_matrix),
    Builtin("transpose", 1, "function", _transposed, "a 3x3 matrix", _transpose_of),
    Builtin("euler_zxz", 3, "function", _rotation, value=_euler("zxz")),
    Builtin("euler_zyx", 3, "function", _rotation, value=_euler("zyx")),
    Builtin("omega_body", 1, "function", _body_angular_velocity, "a 3x3 matrix", _velocity_in_body, rates=True),
    Builtin("omega_zxz", 3, "function", _angular_velocity, value=_euler_rates("zxz"), rates=True),
    Builtin("omega_zyx", 3, "function", _angular_velocity, value=_euler_rates("zyx"), rates=True),
    # the total time derivative and sums (docs/language.md, "Expressions")
    Builtin("der", 1, "special", _rate),
    Builtin("sum", 2, "special", _summed),
    # values of the solved motion, for outputs (docs/language.md, "Scenes")
    Builtin("momentum", 1, "observable", _momentum),
    Builtin("multiplier", 1, "observable", _multiplier),
    Builtin("residual", 1, "observable", _residual),
)
BUILTINS = {f.name: f for f in TABLE if isinstance(f, Builtin)}
OBSERVABLES = tuple(name for name, f in BUILTINS.items() if f.kind == "observable")
# The names a model calls as functions within expressions (observables aside), for suggestions.
FUNCTION_NAMES = sorted(name for name, f in BUILTINS.items() if f.kind != "observable")
PRINTED = tuple(f for f in BUILTINS.values() if isinstance(f.value, type))   # a sympy function class


def libm_table() -> str:
    """The #defines of runtime.h's libm table: r_sqrt is LAG_FN(sqrt), which is sqrt, sqrtl or
    sqrtq by the working precision."""
    return "".join(f"#define r_{f.c} LAG_FN({f.c})\n" for f in TABLE if f.c is not None)
