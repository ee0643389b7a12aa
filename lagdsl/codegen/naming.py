"""Target-safe names for everything a kernel block reads or computes.

Every symbol a block emits is renamed: parameters p_NAME, coordinates q_NAME and velocities
v_NAME, accelerations a_NAME, multipliers lam_NAME, the user's lets let_NAME, velocities of
lets der_NAME, other intermediates wN and CSE temporaries cN. None can collide with a C or
Python keyword, libm or POSIX names, or another symbol's name.
"""
from __future__ import annotations

import keyword
import re

import sympy

from .. import ir
from ..calculus import Differentiator
from ..errors import InternalError

INPUT_ARRAYS = ("par", "y", "acc", "lam", "t")      # the order of a block's inputs


def safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", text.replace("[", "_").replace("]", "")).strip("_") or "x"


IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if "
    "inline int long register restrict return short signed sizeof static struct switch typedef "
    "union unsigned void volatile while _Bool _Complex _Imaginary".split())


def is_target_name(name: str) -> bool:
    """A valid identifier of both targets: C99 (not a keyword) and Python (not a keyword)."""
    return (IDENTIFIER.fullmatch(name) is not None and name not in C_KEYWORDS
            and not keyword.iskeyword(name))


def check_target_names(rename: dict[sympy.Symbol, sympy.Symbol]) -> None:
    """Every name a block emits must print as itself in C and Python, and name one symbol.

    A symbol that missed the name table would otherwise surface as a C compiler error or a
    Python SyntaxError in generated code; here it is our bug, reported where it happens.
    """
    owners: dict[str, sympy.Symbol] = {}
    for symbol, target in rename.items():
        if not is_target_name(target.name):
            raise InternalError(f"the kernel name {target.name!r} of {symbol} is not a C and Python identifier")
        if owners.setdefault(target.name, symbol) != symbol:
            raise InternalError(f"the kernel name {target.name!r} stands for both {owners[target.name]} "
                                f"and {symbol}")


class NameTable:
    """The names of a kernel's inputs and intermediates, and where each input is read from
    (`sources`: "par[0]", "y[3]", "acc[1]", "lam[0]", "t")."""

    def __init__(self, model: ir.Model, calculus: Differentiator, accelerations, active, multipliers):
        self.model, self.calculus = model, calculus
        self.accelerations, self.active, self.multipliers = accelerations, active, multipliers
        n = len(model.coordinates)
        self.sources: dict[sympy.Symbol, str] = {ir.TIME: "t"}
        self.sources.update({p.symbol: f"par[{i}]" for i, p in enumerate(model.parameters)})
        self.sources.update({c.symbol: f"y[{k}]" for k, c in enumerate(model.coordinates)})
        self.sources.update({c.velocity_symbol: f"y[{n + k}]" for k, c in enumerate(model.coordinates)})
        self.sources.update({s: f"acc[{k}]" for k, s in enumerate(accelerations)})
        self.sources.update({s: f"lam[{i}]" for i, s in enumerate(multipliers)})
        self.names: dict[sympy.Symbol, str] = {ir.TIME: "t"}
        self._taken: set[str] = {"t"}
        self._name_table()

    def claim(self, symbol: sympy.Symbol, wanted: str) -> None:
        name, counter = wanted, 1
        while name in self._taken:
            counter += 1
            name = f"{wanted}_{counter}"
        self._taken.add(name)
        self.names[symbol] = name

    def _name_table(self) -> None:
        """Names of the inputs and of the intermediates the equations define."""
        for p in self.model.parameters:
            self.claim(p.symbol, "p_" + safe_name(p.name))
        for c in self.model.coordinates:
            self.claim(c.symbol, "q_" + safe_name(c.name))
            self.claim(c.velocity_symbol, "v_" + safe_name(c.name))
        for c, a in zip(self.model.coordinates, self.accelerations):
            self.claim(a, "a_" + safe_name(c.name))
        for c, lam in zip(self.active, self.multipliers):
            self.claim(lam, "lam_" + safe_name(c.name))
        self.name_new_intermediates()

    def name_new_intermediates(self) -> None:
        """Name the intermediates not named yet, in definition order.

        Lowering differentiates too (the Jacobian's ∂R/∂y), and every derivative it names
        becomes a new intermediate after the table was first built.
        """
        user_lets = {let.symbol for let in self.model.lets if let.span is not None}
        for index, (symbol, _) in enumerate(self.calculus.definitions()):
            if symbol in self.names:
                continue
            if symbol in user_lets:
                self.claim(symbol, "let_" + safe_name(symbol.name))
            elif symbol.name.startswith("der(") and symbol.name.count("(") == 1:
                self.claim(symbol, "der_" + safe_name(symbol.name[4:-1]))
            else:
                self.claim(symbol, f"w{index}")

    def input_order(self, symbol):
        source = self.sources.get(symbol, "")
        array, _, rest = source.partition("[")
        return (INPUT_ARRAYS.index(array) if array in INPUT_ARRAYS else 9,
                int(rest[:-1]) if rest else 0)
