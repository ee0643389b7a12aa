"""Unit annotations, `[kg]`, `[m/s^2]`, `[kg*m^2/s]`, `[mJ]`, `[1]`, and the dimensions they carry.

A unit is a product of named units with rational exponents. The names are looked up in pint's
unit registry (SI base and derived units, prefixes, `deg`, `rpm`, ...): it gives each name its
dimension (a product of powers of mass, length, time, current, temperature, substance and
luminosity) and its factor to SI (`cm` is 0.01 m). Radians are dimensionless; `is_angle` keeps
them apart for display. The dimensional analysis of expressions is in `dimensions.py`.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from fractions import Fraction

import sympy

from ..errors import InputError, LagError, Setting
from ..ir import Unit
from ..given_values import SECONDS, InputUnit, scaled_to_si
from ..source import SourceFile, Span
from . import known_units

BASE_DIMENSIONS = ("mass", "length", "time", "current", "temperature", "substance", "luminosity")
SI_SYMBOLS = {"mass": "kg", "length": "m", "time": "s", "current": "A", "temperature": "K",
              "substance": "mol", "luminosity": "cd"}
NAMED_SI_UNITS = ("N", "J", "W")        # shown instead of their base units: a force, an energy, a power


@dataclass(frozen=True)
class Dimension:
    """A product of powers of the base dimensions: {mass: 1, length: 2, time: -2} is an energy."""

    exponents: tuple[tuple[str, Fraction], ...] = ()

    @staticmethod
    def of(**exponents) -> "Dimension":
        return Dimension(tuple(sorted((k, Fraction(v)) for k, v in exponents.items() if v != 0)))

    def __mul__(self, other: "Dimension") -> "Dimension":
        merged = dict(self.exponents)
        for name, power in other.exponents:
            merged[name] = merged.get(name, Fraction(0)) + power
        return Dimension.of(**merged)

    def __pow__(self, power) -> "Dimension":
        return Dimension.of(**{name: p * Fraction(power) for name, p in self.exponents})

    def __truediv__(self, other: "Dimension") -> "Dimension":
        return self * other ** -1

    @property
    def dimensionless(self) -> bool:
        return not self.exponents

    def words(self) -> str:
        """mass*length^2/time^2, in base dimensions ("1" when dimensionless)."""
        return _product(self.exponents, {name: name for name in BASE_DIMENSIONS})

    def si(self) -> str:
        """The SI unit of this dimension, `kg*m/s^2` or a named one (`N`, `J`, `W`); `1` if none."""
        for name in NAMED_SI_UNITS:
            if unit_dimension(name) == self:
                return name
        return _product(self.exponents, SI_SYMBOLS)


def _product(exponents, names: dict[str, str]) -> str:
    order = {name: i for i, name in enumerate(BASE_DIMENSIONS)}
    ordered = sorted(exponents, key=lambda item: order.get(item[0], len(order)))
    upper = "*".join(_power(names.get(n, n), p) for n, p in ordered if p > 0)
    lower = [_power(names.get(n, n), -p) for n, p in ordered if p < 0]
    text = upper or "1"
    if lower:
        text += "/" + (lower[0] if len(lower) == 1 else "(" + "*".join(lower) + ")")
    return text


def _power(name: str, power: Fraction) -> str:
    if power == 1:
        return name
    return f"{name}^{power}" if power.denominator == 1 else f"{name}^({power})"


@functools.cache
def _registry():
    """pint's registry, its parsed definitions kept in the build cache (trusted as the builds
    are: private to the user): reading pint's definition files costs about 0.4 s a process."""
    import pint            # loaded when a model has units: it takes a moment

    from ..run.cache import helper_directory
    directory = helper_directory("pint")
    try:
        return pint.UnitRegistry(cache_folder=directory)
    except (OSError, ImportError):      # a cache that cannot be written, or pint without its cache's packages
        return pint.UnitRegistry()


@functools.cache
def _named_unit(name: str) -> tuple[Dimension, Fraction, bool] | None:
    """(dimension, factor to SI, is an angle) of a unit name such as `cm`, None if unknown: from
    the table of the common names (known_units.py), else from pint.

    Raises ValueError for a unit with an offset (`degC`): it has no factor to SI."""
    known = known_units.lookup(name)
    if known is None:
        return resolve_with_pint(name)
    exponents, factor, angle = known
    return Dimension.of(**{base: Fraction(power) for base, power in exponents.items()}), Fraction(factor), angle


def resolve_with_pint(name: str) -> tuple[Dimension, Fraction, bool] | None:
    """_named_unit's answer, asked of pint's registry."""
    registry = _registry()
    if not registry.parse_unit_name(name):
        return None
    if registry.Quantity(0, name).to_base_units().magnitude != 0:
        raise ValueError(name)
    dimension = Dimension.of(**{k.strip("[]"): v for k, v in registry.Unit(name).dimensionality.items()})
    angle = "radian" in str(registry.Quantity(1, name).to_root_units().units)
    magnitude = float(registry.Quantity(1, name).to_base_units().magnitude)
    # 16 digits drop the last-bit noise of pint's composed factors (a kL is 1.0000000000000002 m^3);
    # an angle's factor is one division of pi, correctly rounded, so all 17 are kept: 30 deg is pi/6
    factor = Fraction(repr(magnitude) if angle else f"{magnitude:.16g}")
    return dimension, factor, angle


def unit_dimension(text: str) -> Dimension:
    """The dimension of one unit name known to the registry."""
    return _named_unit(text)[0]


def dimension(unit: Unit) -> Dimension:
    result = Dimension()
    for name, power in unit.factors:
        result = result * _named_unit(name)[0] ** power
    return result


def si_factor(unit: Unit) -> sympy.Expr:
    """What a number in `unit` is multiplied by to be in SI: 0.01 for `[cm]`, exactly."""
    factor = sympy.S.One
    for name, power in unit.factors:
        factor *= sympy.Rational(_named_unit(name)[1]) ** sympy.Rational(power)
    return factor


def in_si(value: sympy.Expr, unit: Unit | None) -> sympy.Expr:
    """A value given with a unit, in SI: a number is in the unit (`40 [cm]` is 2/5), an expression
    of parameters is computed in SI already (its dimension is checked against the unit)."""
    return value * si_factor(unit) if unit is not None and not value.free_symbols else value


def is_angle(unit: Unit) -> bool:
    """`[rad]`, `[deg]`: dimensionless, but an angle (shown as rad)."""
    return dimension(unit).dimensionless and any(_named_unit(name)[2] for name, _ in unit.factors)

# A value given with its unit outside the model file: `30 deg`, `500g`, `0.785 [rad]`.
_VALUE_WITH_UNIT = re.compile(r"\s*(?P<number>[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*"
                              r"(?:\[(?P<bracketed>[^\]]*)\]|(?P<bare>[A-Za-z_][^\[\]]*))\s*")


def input_unit(unit: Unit | None) -> InputUnit | None:
    """What a value set from outside the model needs of its declared unit (given_values.input_in_si)."""
    return None if unit is None else InputUnit(unit.text, Fraction(si_factor(unit)))


def time_in_seconds(value: float | str | None, option: str) -> float | None:
    """A time given outside the model file (`--stop`, simulate(stop=...)): a number in seconds,
    or a number and a unit of time (`0.8 ns`, `2 min`)."""
    if not isinstance(value, str):
        return value
    return value_in_si(value, SECONDS, Setting(option))


def _written_unit(text: str) -> Unit:
    """A unit written outside a model file (no brackets), parsed as a model's `[text]` is."""
    return parse_unit(Span(SourceFile("<value>", f"[{text}]"), 1, 1, 0, len(text) + 2))


def per_second(unit: Unit | None) -> Unit | None:
    """The unit of the rate of a quantity in `unit` (a coordinate's velocity)."""
    if unit is None:
        return None
    factors = dict(unit.factors)
    factors["s"] = factors.get("s", Fraction(0)) - 1
    text = unit.text if re.fullmatch(r"\w+", unit.text) else f"({unit.text})"
    return Unit(f"{text}/s", tuple(sorted((n, p) for n, p in factors.items() if p != 0)), unit.span)


def si_text(unit: Unit) -> str:
    """The SI unit a quantity declared in `unit` is computed in: `kg` for [g], `rad` for [deg],
    `rad/s` for [deg/s], `N` for [kN]."""
    si = dimension(unit).si()
    if angle_power(unit) != 1:
        return si
    return "rad" if si == "1" else "rad" + si[1:] if si.startswith("1/") else f"rad*{si}"


def value_in_si(text: str, declared: InputUnit | None, where) -> float:
    """A value written with a unit (`30 deg`, `500g`, `0.785 [rad]`) in SI, where the quantity it
    sets is declared in `declared`; its dimension must be that unit's. The number is read as a
    double and scaled as a plain number is (given_values.scaled_to_si): `30 deg` runs as 30 given for a
    value declared in deg. Raises LagError at `where` (an errors.Setting) for text that is no
    number and unit, an unknown unit, a quantity declared without a unit, or another dimension."""
    match = _VALUE_WITH_UNIT.fullmatch(text)
    if match is None:
        raise InputError(f"expected a number, or a number and a unit such as '30 deg', got '{text}'", where)
    written = match.group("bracketed") if match.group("bracketed") is not None else match.group("bare")
    try:
        unit = _written_unit(written.strip())
    except LagError as error:
        raise InputError(f"in '{text}': {error.diagnostics[0].message}", where) from None
    if declared is None:
        raise InputError(f"'{text}' has a unit, but the model declares none for this value: give a plain number", where)
    expected = dimension(_written_unit(declared.text))
    if dimension(unit) != expected:
        raise InputError(f"'{text}' is a {dimension(unit).words()}, but this value is declared in [{declared.text}] "
                       f"({expected.words() if not expected.dimensionless else 'dimensionless'})", where)
    return scaled_to_si(float(match.group("number")), Fraction(si_factor(unit)))


_TOKEN = re.compile(r"\s*(?:(?P<name>[A-Za-z_][A-Za-z_0-9]*)|(?P<number>\d+(?:\.\d+)?)|(?P<op>\*\*|[*/^()\-+.]))")


def parse_unit(span: Span) -> Unit:
    """Parse the text of a UNIT token (with its brackets) located at `span`."""
    body = span.text[1:-1]
    tokens = _tokenize(body, span)
    if not tokens:
        raise LagError("empty unit: write [1] for a dimensionless quantity", span)
    parser = _UnitParser(tokens, span)
    factors = parser.product()
    if parser.position < len(tokens):
        parser.fail(f"expected '*', '/' or the end of the unit, found '{tokens[parser.position][1]}'")
    cleaned = tuple(sorted((name, power) for name, power in factors.items() if power != 0))
    return Unit(body.strip(), cleaned, span)


def _tokenize(body: str, span: Span) -> list[tuple[str, str, int]]:
    tokens, position = [], 0
    while position < len(body):
        if body[position:].strip() == "":
            break
        match = _TOKEN.match(body, position)
        if not match:
            raise LagError(f"unexpected character '{body[position]}' in unit",
                           _inner(span, position))
        kind = match.lastgroup
        tokens.append((kind, match.group(kind), match.start(kind)))
        position = match.end()
    return tokens


def _inner(span: Span, offset: int) -> Span:
    return Span(span.source, span.line, span.column + 1 + offset, span.start + 1 + offset,
                span.start + 2 + offset)


class _UnitParser:
    def __init__(self, tokens, span):
        self.tokens, self.span, self.position = tokens, span, 0

    def fail(self, message: str):
        offset = self.tokens[self.position][2] if self.position < len(self.tokens) else len(self.span.text) - 2
        raise LagError(message, _inner(self.span, offset))

    def require_known(self, name: str) -> None:
        self.position -= 1
        try:
            known = _named_unit(name) is not None
        except ValueError:
            self.fail(f"'{name}' is a unit with an offset; write the temperature in K")
        if not known:
            self.fail(f"unknown unit '{name}' (units are SI base and derived units with prefixes: "
                      "kg, g, m, cm, s, N, J, mJ, rad, deg, ...)")
        self.position += 1

    def peek(self) -> str | None:
        return self.tokens[self.position][1] if self.position < len(self.tokens) else None

    def take(self, expected: str = "a unit name") -> tuple[str, str, int]:
        if self.position >= len(self.tokens):
            after = f" after '{self.tokens[-1][1]}'" if self.tokens else ""
            self.fail(f"the unit ends too early: expected {expected}{after}")
        token = self.tokens[self.position]
        self.position += 1
        return token

    def product(self) -> dict[str, Fraction]:
        factors = self.power()
        while self.peek() in ("*", "/", "."):
            sign = -1 if self.take()[1] == "/" else 1
            for name, power in self.power().items():
                factors[name] = factors.get(name, Fraction(0)) + sign * power
        return factors

    def power(self) -> dict[str, Fraction]:
        base = self.atom()
        if self.peek() in ("^", "**"):
            self.take()
            exponent = self.exponent()
            base = {name: power * exponent for name, power in base.items()}
        return base

    def exponent(self) -> Fraction:
        sign = 1
        if self.peek() in ("-", "+"):
            sign = -1 if self.take()[1] == "-" else 1
        if self.peek() == "(":
            self.take()
            value = self.exponent()
            if self.peek() == "/":
                self.take()
                divisor = self.exponent()
                if divisor == 0:
                    self.position -= 1
                    self.fail("division by zero in a unit exponent")
                value /= divisor
            if self.take("')'")[1] != ")":
                self.position -= 1
                self.fail("expected ')' in unit exponent")
            return sign * value
        kind, text, _ = self.take("an exponent")
        if kind != "number":
            self.position -= 1
            self.fail(f"expected a number as unit exponent, found '{text}'")
        return sign * Fraction(text)

    def atom(self) -> dict[str, Fraction]:
        kind, text, _ = self.take()
        if kind == "name":
            self.require_known(text)
            return {text: Fraction(1)}
        if kind == "number" and Fraction(text) == 1:
            return {}
        if text == "(":
            inner = self.product()
            if self.take("')'")[1] != ")":
                self.position -= 1
                self.fail("expected ')' in unit")
            return inner
        self.position -= 1
        if kind == "number":
            self.fail(f"unexpected '{text}' in unit: the only number allowed is 1, as in [1/s], or an exponent")
        self.fail(f"unexpected '{text}' in unit: expected a unit name")


def angle_power(unit: Unit) -> Fraction:
    """The power of angle units in `unit`: 1 for [rad/s], -1 for [1/deg] (the dimension leaves
    angles out: they are dimensionless)."""
    return sum((Fraction(power) for name, power in unit.factors if _named_unit(name)[2]), Fraction(0))
