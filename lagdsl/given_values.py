"""Values set from outside the model file (`--set`, `simulate(set=)`, sweep members, a fit's trials,
a time or an integrator option), in SI: a plain number is in the declared unit of what it sets, as
in the model file (and as in Modelica); a text carries its own unit. Nothing here needs sympy or
the parser unless a text with a unit is given."""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

from .errors import Setting


@dataclass(frozen=True)
class InputUnit:
    """The declared unit of a value that can be set from outside the model file (a parameter,
    "q.start", "q.velocity"): as written (`g`, `deg`, `deg/s`) and its exact factor to SI."""

    text: str
    factor: Fraction


def scaled_to_si(value: float, factor: Fraction) -> float:
    """A number in a unit whose factor to SI is `factor`, in SI: the number as a double times the
    exact factor, rounded once. The generated C program does the same (lag_in_si, with the factor
    as a double and its remainder), so that `theta.start=30` there runs as `--set theta.start=30`."""
    if factor == 1 or not math.isfinite(value):
        return float(value)
    return float(Fraction(float(value)) * factor)


class InSI(float):
    """A value already in SI, taken as it is: a fit's trial values, which its Jacobian (the
    sensitivities) is taken against."""


def input_in_si(name: str, value: float | str, unit: InputUnit | None) -> float:
    """A value set from outside the model file, in SI: a plain number is in the declared `unit` of
    what it sets (as in the model file, and as in Modelica), a text carries its own unit ("30 deg",
    "500g"), checked against the declared one (frontend/units.value_in_si). Every path that sets a
    value from outside (`--set`, `simulate(set=)`, sweep members, fit, the warm plan) converts
    through here; a scene's `set` scales its numbers by the same scaled_to_si (compile_time.py)."""
    if isinstance(value, str):
        # pint and sympy, imported only for a value with a unit
        from .frontend.units import value_in_si
        return value_in_si(value, unit, Setting(name))
    if isinstance(value, InSI):
        return float(value)
    return scaled_to_si(value, unit.factor) if unit is not None else float(value)


SECONDS = InputUnit("s", Fraction(1))       # the unit of a time set from outside the model file
