"""The unit names most models write, as pint resolves them, kept in known_units.json.

A model that writes only these names is checked without pint: its import and its registry cost
about 0.9 s of CPU on a first run (0.5 s with the registry's definitions in the build cache),
more than the rest of `lagc check`. The file holds, for each name, its dimension (base
dimensions and their exponents), its factor to SI and whether it is an angle, exactly as
units.resolve_with_pint gives them; pint stays the one source: the file is written from it by

    python -m lagdsl.frontend.known_units

and tests/test_units.py checks that every entry still says what pint says. A name not in the
file is looked up in pint, as before.
"""
from __future__ import annotations

import functools
import json
from pathlib import Path

TABLE = Path(__file__).with_name("known_units.json")
# SI units and the usual prefixes; the angles and times of everyday use
BASES = ("m", "g", "s", "A", "K", "mol", "cd", "N", "J", "W", "Pa", "Hz", "C", "V", "T", "F", "H", "Wb", "ohm",
         "L", "eV", "rad")
PREFIXES = ("", "k", "M", "G", "c", "m", "u", "n", "p")
OTHERS = ("deg", "degree", "rpm", "min", "h", "hour", "day", "turn", "revolution", "radian", "meter", "second",
          "kilogram", "gram", "newton", "joule", "watt", "percent")
# names the supported pint versions read differently, left to the installed pint: "mcd" is the
# millicandela in pint 0.21 and a milli-centi-day (a time) in pint 0.24
VERSION_DEPENDENT = frozenset({"mcd"})


@functools.cache
def _table() -> dict[str, list]:
    try:
        return json.loads(TABLE.read_text(encoding="utf-8"))
    except OSError:         # a copy of lagdsl without its data: pint answers every name
        return {}


def lookup(name: str) -> tuple[dict[str, str], str, bool] | None:
    """(base dimension -> exponent as a text, factor to SI as a text, is an angle) of `name`, or
    None where the table does not hold it."""
    entry = _table().get(name)
    return None if entry is None else (entry[0], entry[1], entry[2])


def names() -> list[str]:
    every = [prefix + base for base in BASES for prefix in PREFIXES] + list(OTHERS)
    return [name for name in every if name not in VERSION_DEPENDENT]


def entries() -> dict[str, list]:
    """The table as pint gives it now (names pint does not know, or knows with an offset, left out)."""
    from .units import resolve_with_pint
    table = {}
    for name in names():
        try:
            resolved = resolve_with_pint(name)
        except ValueError:
            continue
        if resolved is not None:
            dimension, factor, angle = resolved
            table[name] = [{base: str(power) for base, power in dimension.exponents}, str(factor), angle]
    return table


def text(table: dict[str, list]) -> str:
    """The file: one name a line, in order."""
    lines = (f"{json.dumps(name)}: {json.dumps(entry, sort_keys=True)}" for name, entry in sorted(table.items()))
    return "{\n" + ",\n".join(lines) + "\n}\n"


if __name__ == "__main__":
    TABLE.write_text(text(entries()), encoding="utf-8")
