"""The units of an FMU's variables (from the model's UnitReport, dimensions.py) and their
definitions in modelDescription.xml: each unit's exponents of the SI base units (and of rad) and
its factor to them, so that a value v in the unit is factor * v in the base units.

A model without units gives none ("?"); so does a quantity whose unit could not be inferred.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from .. import ir
from ..source import SourceFile, Span
from ..frontend.units import SI_SYMBOLS, Dimension, angle_power, dimension, parse_unit, si_factor, unit_dimension

UNKNOWN = "?"


@dataclass(frozen=True)
class UnitDefinition:
    """`name` as the variables name it; `exponents` of kg, m, s, A, K, mol, cd and rad (None where
    one is not whole: FMI's are integers); value in base units = factor * value in the unit."""

    name: str
    exponents: dict[str, int] | None
    factor: float


class VariableUnits:
    """The unit of each variable of an FMU of scene `scene` ("?" when unknown)."""

    def __init__(self, model: ir.Model, scene: str):
        self.report, self.scene = model.units, scene
        self.listed = {column: unit for owner, column, unit in (model.units.columns if model.units else ())
                       if owner == scene}

    def of(self, name: str) -> str:
        """A parameter's or a coordinate's unit (SI, "rad" for an angle)."""
        return self.report.unit_of(name) if self.report else UNKNOWN

    @property
    def time(self) -> str:
        return "s" if self.report else UNKNOWN

    def rate(self, coordinate: str, order: int) -> str:
        """The unit of the coordinate's velocity (order 1) or acceleration (order 2)."""
        unit = self.of(coordinate)
        if unit in (UNKNOWN, "rad"):
            return unit if unit == UNKNOWN else "rad/s" if order == 1 else f"rad/s^{order}"
        return (unit_dimension_of(unit) * unit_dimension("s") ** -order).si()

    def column(self, request: ir.OutputRequest) -> str:
        """An output column's: the scene's list says it, else the kind of observable does."""
        if not self.report:
            return UNKNOWN
        if request.column in self.listed:
            return self.listed[request.column]
        if request.kind == "energy":
            return "J"
        if request.kind == "momentum" and self.of(request.target) != UNKNOWN:
            return (unit_dimension("J") * unit_dimension("s") * unit_dimension_of(self.of(request.target)) ** -1).si()
        return self.report.unit_of(request.column) if request.kind == "expression" else UNKNOWN


def unit_dimension_of(text: str) -> Dimension:
    return dimension(_parsed(text))


def unit_definition(text: str) -> UnitDefinition:
    """The definition of the unit `text` (as the UnitReport writes units: "kg*m/s^2", "N", "rad")."""
    unit = _parsed(text)
    powers = {SI_SYMBOLS[name]: power for name, power in dimension(unit).exponents}
    if angle_power(unit):
        powers["rad"] = angle_power(unit)
    whole = all(Fraction(power).denominator == 1 for power in powers.values())
    return UnitDefinition(text, {name: int(power) for name, power in powers.items()} if whole else None,
                          float(si_factor(unit)))


def _parsed(text: str) -> ir.Unit:
    """`text` read by the parser of [unit] annotations, as if written in a model."""
    source = SourceFile("<unit>", f"[{text}]")
    return parse_unit(Span(source, 1, 1, 0, len(source.text)))
