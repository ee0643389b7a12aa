"""Unit annotations: `[kg]`, `[m/s^2]`, `[kg*m^2/s]`, `[1]`.

Units are parsed now and kept on the IR (parameters, coordinates, outputs) so that
dimensional analysis can be added without touching the grammar. A unit is a product of
named base units with rational exponents; the names are not yet checked against a table.
"""
from __future__ import annotations

import re
from fractions import Fraction

from .errors import LagError
from .ir import Unit
from .source import Span

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
