"""Seeded mutations of `.lag` models, for the fuzz campaign (`campaign.py`) and its CI slice.

A mutant is a library model with one to three mutations. Character and token mutations mostly
break the syntax and test the parser's messages; line deletion and duplication break the
declarations (missing or repeated names); numeric mutations keep the model well-formed and carry
extreme values (0, -1, 1e308, subnormals, overflow, expressions that give inf or NaN, huge
exponents) into the derivation, the generated code and the integrators. Numeric mutations are
drawn more often, since they get further down the pipeline.
"""
from __future__ import annotations

import random
import re
from dataclasses import dataclass
from pathlib import Path

# Comments, strings, units and numbers are single tokens; so is every other word or symbol.
TOKEN = re.compile(r"//[^\n]*|\"[^\"\n]*\"|\[[^\]\n]*\]|\d*\.?\d+(?:[eE][+-]?\d+)?|\w+|\S")
NUMBER = re.compile(r"(?<![\w.])\d*\.?\d+(?:[eE][+-]?\d+)?(?![\w.])")

EXTREMES = ["0", "0.0", "-1", "1e308", "-1e308", "1e-310", "1e-320", "1e999", "1e-999", "4e9", "1e-300"]
NON_FINITE = ["(1/0)", "(0/0)", "(1e308*10)", "sqrt(-1)", "log(0)", "acos(2)", "exp(1000)", "(1e308 - 1e308*2)",
              "(0*1e999)", "tan(pi/2)", "(-1)^0.5", "atan2(0, 0)"]
EXPONENTS = ["^1e300", "^100000", "^(-1)", "^0", "^(-400)", "^1e-300", "^(1/0)", "^2^2^2^2^2"]
WORDS = ["model", "end", "parameter", "coordinate", "let", "constraint", "force", "dissipation", "output",
         "scene", "time", "integrator", "in", "T", "U", "L", "der", "sum", "sin", "sqrt", "energy", "momentum",
         "rk4", "gauss", "radau5", "dopri5", "x", "t", "pi", "(", ")", "{", "}", ";", ",", "=", "^", "/", "[m]"]
CHARACTERS = list("abxyzTUL019.eE+-*/^=;:,()[]{}\"' \t\n_@#\\") + ["θ", "\x00", "\r"]


@dataclass(frozen=True)
class Mutant:
    model: str                   # the library model's file name
    text: str
    mutations: tuple[str, ...]   # what was done, for the report


def library(models: Path) -> dict[str, str]:
    return {path.name: path.read_text(encoding="utf-8") for path in sorted(models.glob("*.lag"))}


def mutants(seeds: dict[str, str], rng: random.Random):
    """An endless stream of mutants of the `seeds` (file name -> text), reproducible from `rng`."""
    names = sorted(seeds)
    while True:
        name = rng.choice(names)
        text, done = seeds[name], []
        for _ in range(rng.choice((1, 1, 2, 3))):
            operation = rng.choices(OPERATIONS, WEIGHTS)[0]
            text, description = operation(text, rng)
            done.append(description)
        yield Mutant(name, text, tuple(done))


# ---- characters ------------------------------------------------------------------------------
def change_character(text: str, rng: random.Random) -> tuple[str, str]:
    at = rng.randrange(len(text) + 1)
    kind = rng.choice(("insert", "delete", "replace"))
    new = rng.choice(CHARACTERS) if kind != "delete" else ""
    end = at if kind == "insert" else at + 1
    return text[:at] + new + text[end:], f"{kind} character {text[at:end]!r}->{new!r} at {at}"


# ---- tokens ----------------------------------------------------------------------------------
def change_token(text: str, rng: random.Random) -> tuple[str, str]:
    spans = [m.span() for m in TOKEN.finditer(text)]
    start, end = rng.choice(spans)
    kind = rng.choice(("delete", "duplicate", "insert", "swap"))
    if kind == "delete":
        return text[:start] + text[end:], f"delete token {text[start:end]!r} at {start}"
    if kind == "duplicate":
        return text[:end] + " " + text[start:end] + text[end:], f"duplicate token {text[start:end]!r} at {start}"
    if kind == "insert":
        word = rng.choice(WORDS)
        return text[:start] + word + " " + text[start:], f"insert token {word!r} at {start}"
    other_start, other_end = rng.choice(spans)
    if other_start < end:
        (start, end), (other_start, other_end) = (other_start, other_end), (start, end)
    if other_start < end:        # the same token drawn twice
        return text, "swap a token with itself"
    return (text[:start] + text[other_start:other_end] + text[end:other_start] + text[start:end] + text[other_end:],
            f"swap tokens {text[start:end]!r} at {start} and {text[other_start:other_end]!r} at {other_start}")


# ---- lines -----------------------------------------------------------------------------------
def change_line(text: str, rng: random.Random) -> tuple[str, str]:
    lines = text.split("\n")
    at = rng.randrange(len(lines))
    if rng.random() < 0.5:
        return "\n".join(lines[:at] + lines[at + 1:]), f"delete line {at + 1}"
    return "\n".join(lines[:at + 1] + lines[at:]), f"duplicate line {at + 1}"


# ---- numbers ---------------------------------------------------------------------------------
def replace_number(text: str, rng: random.Random, choices: list[str], what: str) -> tuple[str, str]:
    numbers = [m for m in NUMBER.finditer(text) if "//" not in text[text.rfind("\n", 0, m.start()) + 1:m.start()]]
    if not numbers:
        return change_character(text, rng)
    number = rng.choice(numbers)
    new = rng.choice(choices)
    line = text.count("\n", 0, number.start()) + 1
    return text[:number.start()] + new + text[number.end():], f"{what}: {number.group()} -> {new} on line {line}"


def extreme_number(text: str, rng: random.Random) -> tuple[str, str]:
    return replace_number(text, rng, EXTREMES, "extreme value")


def non_finite_number(text: str, rng: random.Random) -> tuple[str, str]:
    return replace_number(text, rng, NON_FINITE, "non-finite expression")


def huge_exponent(text: str, rng: random.Random) -> tuple[str, str]:
    """Raise a number or a name inside an expression (after `=`) to an extreme power."""
    places = [m.end() for m in re.finditer(r"(?<==)[^;\n]*?(?:\d*\.?\d+(?:[eE][+-]?\d+)?|[A-Za-z_]\w*)", text)]
    if not places:
        return change_character(text, rng)
    at, power = rng.choice(places), rng.choice(EXPONENTS)
    return text[:at] + power + text[at:], f"exponent {power} at line {text.count(chr(10), 0, at) + 1}"


OPERATIONS = [change_character, change_token, change_line, extreme_number, non_finite_number, huge_exponent]
WEIGHTS = [2, 2, 1, 3, 3, 2]
