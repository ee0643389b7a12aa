"""The unit annotation parser: base factors of well-formed units, located errors otherwise."""
from __future__ import annotations

from fractions import Fraction

import pytest

from lagdsl.errors import LagError
from lagdsl.source import SourceFile, Span
from lagdsl.units import parse_unit


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
