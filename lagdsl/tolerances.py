"""Absolute tolerances per component of the state y = (q, q') of the adaptive integrators.

One `atol` weighs every component alike (HNW I, II.4, (4.11): |e_i| <= atol + rtol |y_i|), which
fails a model in SI scales: an electron's x ~ 1e-3 m and x' ~ 1e8 m/s need absolute tolerances
eleven orders apart. A component is therefore given its own, by name, the same way everywhere:

    integrator dop853(rtol = 1e-12, atol = 1e-10, atol(x) = 1e-18, atol(der(x)) = 1e-6);
    lagc run ... --atol 1e-10 --atol x=1e-18 --atol "der(x)=1e-6"
    simulate(atol=1e-10)  or  simulate(atol={"x": 1e-18, "der(x)": 1e-6})

A name is a coordinate (`x`, a member `q[2]`, or a family `q` for all its members) or its velocity
`der(x)`; a plain number is in the component's declared unit (the coordinate's, or that per second
for a velocity), as every value given from outside the model file is (given_values.input_in_si); a
text may carry its own unit ("1e-15 mm"). `component_input` names the input whose unit that is.
The plan holds the values in SI. A component not
named keeps the scalar atol. A coordinate named without its velocity gives the velocity
atol(x) / (t1 - t0): a velocity error that stays below it moves the coordinate by less than atol(x)
over the whole run, so the velocities are held to the coordinates' accuracy in their own scale.
"""
from __future__ import annotations

import math

from .errors import LagError, suggest


def component_key(text: str) -> str:
    """A component's name without white space: `der( q[2] )` is `der(q[2])`."""
    return "".join(text.split())


def component_names(coordinates: tuple[str, ...]) -> tuple[str, ...]:
    """What a per-component atol may name: each coordinate, each family, each velocity der(q)."""
    families = {name.partition("[")[0] for name in coordinates if "[" in name}
    names = [*coordinates, *sorted(families)]
    return (*names, *(f"der({name})" for name in names))


def component_input(name: str, coordinates: tuple[str, ...]) -> str | None:
    """The input (scene.declared_inputs: "x.start", "x.velocity") whose declared unit a value of
    atol(name) is in: its coordinate's start, or velocity for der(x); a family's first member's.
    None when `name` is no component (check_atol_each says so)."""
    velocity = name.startswith("der(") and name.endswith(")")
    inner = name[4:-1] if velocity else name
    members = [c for c in coordinates if c == inner or c.partition("[")[0] == inner]
    return f"{members[0]}.{'velocity' if velocity else 'start'}" if members else None


def check_component_name(name: str, coordinates: tuple[str, ...], where) -> None:
    """Refuse a `name` of atol(name) that is no component, at `where`."""
    known = component_names(coordinates)
    if name not in known:
        raise LagError(f"atol({name}): '{name}' is not a coordinate of the model nor der() of one"
                       f"{suggest(name, known)} (coordinates: {', '.join(coordinates)})", where)


def check_atol_each(pairs: tuple[tuple[str, float], ...], coordinates: tuple[str, ...], implicit: bool,
                    origins: dict[str, object]) -> None:
    """Refuse a name that is no component and a value that is no tolerance, at `origins[name]`."""
    for name, value in pairs:
        where = origins.get(name)
        check_component_name(name, coordinates, where)
        if not (0 <= value < math.inf):
            raise LagError(f"atol({name}) must be a finite number >= 0, not {value:g}", where)
        if implicit and value == 0:
            raise LagError(f"atol({name}) must be positive: the implicit method weighs each component by "
                           "atol + rtol |y|, which is 0 where a component is 0", where)


def atol_vector(scalar: float, pairs: tuple[tuple[str, float], ...], coordinates: tuple[str, ...],
                span: float) -> tuple[float, ...] | None:
    """The absolute tolerance of each component of y = (q, q'), or None when `pairs` names none
    (then `scalar` is every component's). A family's value comes before its members' own."""
    if not pairs:
        return None
    given = dict(pairs)
    n = len(coordinates)
    values = [scalar] * (2 * n)
    for i, name in enumerate(coordinates):
        for key in (name.partition("[")[0], name):
            if key in given:
                values[i], values[n + i] = given[key], given[key] / span
        for key in (f"der({name.partition('[')[0]})", f"der({name})"):
            if key in given:
                values[n + i] = given[key]
    return tuple(values)

