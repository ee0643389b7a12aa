"""Property: whatever text it is given, the front end either builds a model or raises LagError.

Inputs are (a) the models in models/ with random character and token mutations, (b) random
sequences of the language's tokens, bare or inside a model skeleton, (c) random models built
from the grammar, with random (often ill-typed) expressions, and (d) well-formed models with
random energies, constraints and forces, for the derivation's checks. Each is run through
`model_from_source` and `derive_equations`. Any other exception is a bug in lagdsl, and so is a
rendered LagError that mentions a Python traceback.

The runs are derandomized (the same examples every time) and bounded to keep the file well under
a minute; the campaigns over whole models are marked slow (`pytest --slow`).
"""
from __future__ import annotations

import functools
import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lagdsl.errors import LagError
from lagdsl.mechanics import derive_equations
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile
from tests.conftest import MODELS

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
CHEAP = settings(SETTINGS, max_examples=300)      # mostly syntax errors: fast, so more of them

# The chain is the derivation benchmark; three links exercise the same code in a tenth of the time.
MAX_COORDINATES = 8     # a mutated chain may grow to 93 links: valid, but slow to derive
SEEDS = {path.name: path.read_text(encoding="utf-8").replace("n = 12", "n = 3")
         for path in sorted(MODELS.glob("*.lag"))}
TOKEN = re.compile(r"//[^\n]*|/\*.*?\*/|\"[^\"\n]*\"|\[[^\]\n]*\]|\*\*|[A-Za-z_]\w*|\d+\.?\d*(?:[eE][+-]?\d+)?|\S",
                   re.S)

KEYWORDS = ["model", "end", "parameter", "coordinate", "let", "constraint", "force", "dissipation",
            "output", "scene", "time", "integrator", "set", "in", "T", "U", "L"]
NAMES = ["x", "y", "theta", "m", "l", "g", "n", "i", "j", "r", "rod", "t", "pi", "energy", "A"]
FUNCTIONS = ["der", "sum", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
             "exp", "log", "sqrt", "abs", "sign", "min", "max", "dot", "cross", "norm", "momentum",
             "multiplier", "residual", "rk4", "dopri5", "dop853", "radau5", "gauss"]
NUMBERS = ["0", "1", "2", "2.5", ".5", "1e-3", "3", "12", "0.0", "1e999", "1e-999", "10", "1e308"]
PUNCTUATION = ["+", "-", "*", "/", "^", "**", "=", ";", ":", ",", "(", ")", "[", "]", "{", "}"]
OTHERS = ['"a description"', " [kg]", " [m/s^2]", " [1/s]", " [m^(1/0)]", " [", '"', "//", "/*", "*/",
          "@", "#", "\t", "\n", "θ", "\x00"]
VOCABULARY = KEYWORDS + NAMES + FUNCTIONS + NUMBERS + PUNCTUATION + OTHERS
CHARACTERS = st.sampled_from(list("abcxyzTUL019.eE+-*/^=;:,()[]{}\"' \t\n_@#\\") + ["θ", "\x00", "\r"])


def check(text: str) -> None:
    """The property itself: a model, or a LagError that renders without a traceback."""
    try:
        model = model_from_source(SourceFile("fuzz.lag", text))
        if len(model.coordinates) <= MAX_COORDINATES:
            derive_equations(model)
    except LagError as error:
        rendered = error.render()
        assert "Traceback" not in rendered
        assert error.diagnostics, "a LagError without a diagnostic"


# -- (a) mutations of the valid models -------------------------------------------------------------
@st.composite
def mutated_models(draw) -> str:
    text = SEEDS[draw(st.sampled_from(sorted(SEEDS)))]
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["insert", "delete", "replace", "delete token", "duplicate line",
                                     "swap tokens", "insert token"]))
        if kind in ("insert", "delete", "replace"):
            at = draw(st.integers(0, max(0, len(text) - 1)))
            if kind == "insert":
                text = text[:at] + draw(CHARACTERS) + text[at:]
            elif kind == "delete":
                text = text[:at] + text[at + 1:]
            else:
                text = text[:at] + draw(CHARACTERS) + text[at + 1:]
            continue
        if kind == "duplicate line":
            lines = text.split("\n")
            at = draw(st.integers(0, len(lines) - 1))
            text = "\n".join(lines[:at + 1] + [lines[at]] + lines[at + 1:])
            continue
        spans = [m.span() for m in TOKEN.finditer(text)]
        if not spans:
            continue
        start, end = spans[draw(st.integers(0, len(spans) - 1))]
        if kind == "delete token":
            text = text[:start] + text[end:]
        elif kind == "insert token":
            text = text[:start] + draw(st.sampled_from(VOCABULARY)) + " " + text[start:]
        else:
            other_start, other_end = spans[draw(st.integers(0, len(spans) - 1))]
            if other_start > end:
                text = (text[:start] + text[other_start:other_end] + text[end:other_start]
                        + text[start:end] + text[other_end:])
    return text


@pytest.mark.slow
@CHEAP
@given(mutated_models())
def test_mutated_models_raise_only_lag_errors(text):
    check(text)


# -- (b) token sequences ------------------------------------------------------------------------
@st.composite
def token_sequences(draw) -> str:
    words = draw(st.lists(st.sampled_from(VOCABULARY), max_size=40))
    body = " ".join(words)
    if draw(st.booleans()):          # inside a model skeleton, to get past the first tokens
        body = f"model M\n  coordinate x;\n  T = der(x)^2;\n  {body}\nend M;\n"
    return body


@CHEAP
@given(token_sequences())
def test_token_sequences_raise_only_lag_errors(text):
    check(text)


# -- (c) random models from the grammar -----------------------------------------------------------
# The expression strategies are built once: hypothesis validates a strategy on its first draw,
# and a recursive one built anew for each example was a third of the campaigns' time.
@functools.cache
def expressions(names: tuple[str, ...]):
    leaves = st.one_of(st.sampled_from([*names, "t", "pi", "i", "undefined", "der(x)", "der(y)", "q[1]"]),
                       st.sampled_from(NUMBERS))

    def extend(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "^"]), inner).map(lambda p: f"({p[0]} {p[1]} {p[2]})"),
            inner.map(lambda e: f"-{e}"),
            st.tuples(st.sampled_from(FUNCTIONS[:22]), st.lists(inner, min_size=0, max_size=3)).map(
                lambda p: f"{p[0]}({', '.join(p[1])})"),
            st.tuples(inner, st.sampled_from(["1:2", "1:n", "2:1", "1:2.5"])).map(lambda p: f"sum({p[0]}, i in {p[1]})"),
            st.lists(inner, min_size=2, max_size=4).map(lambda items: "{" + ", ".join(items) + "}"),
            st.tuples(st.sampled_from(["q", "x", "m"]), inner).map(lambda p: f"{p[0]}[{p[1]}]"),
            inner.map(lambda e: f"der({e})"),
        )

    return st.recursive(leaves, extend, max_leaves=8)


@st.composite
def grammar_models(draw) -> str:
    names = ("m", "x", "y", "q")
    expression = expressions(names)
    header = expressions(("m", "n"))          # half of the time a valid value, so that more gets built
    lines = ["model M", "  parameter m = " + draw(st.one_of(st.just("1.5"), header)) + ";", "  parameter n = 2;",
             "  coordinate x(start = " + draw(st.one_of(st.just("0.3"), header)) + ");", "  coordinate y;",
             "  coordinate q[" + draw(st.sampled_from(["2", "2", "2", "n", "m", "0", "2.5"])) + "];"]
    statements = [
        lambda: f"  let a{draw(st.integers(0, 3))} = {draw(expression)};",
        lambda: f"  T = {draw(expression)};",
        lambda: f"  U = {draw(expression)};",
        lambda: f"  L = {draw(expression)};",
        lambda: f"  dissipation = {draw(expression)};",
        lambda: f"  force {draw(st.sampled_from(['x', 'y', 'q[1]', 'm', 'z']))} = {draw(expression)};",
        lambda: f"  constraint c{draw(st.integers(0, 2))}: {draw(expression)} = {draw(expression)};",
        lambda: f"  output o{draw(st.integers(0, 2))} = {draw(expression)};",
        lambda: ("  scene s\n    time(stop = " + draw(expression) + ");\n    integrator "
                 + draw(st.sampled_from(["rk4(step = 0.1)", "dop853", "gauss(stages = 9, step = 1)",
                                         "radau5(rtol = -1)", "dopri5(foo = 1)"]))
                 + ";\n    set " + draw(st.sampled_from(["m = 2", "x(start = 1)", "q[1](velocity = 1)", "n = 3"]))
                 + ";\n    output " + ", ".join(draw(st.lists(st.one_of(expression, st.sampled_from(
                     ["energy", "momentum(x)", "multiplier(c0)", "residual(c1)", "momentum(q[2])"])),
                     min_size=1, max_size=3))) + ";\n  end s;"),
    ]
    lines += [draw(st.sampled_from(statements))() for _ in range(draw(st.integers(1, 6)))]
    if not any(line.startswith(("  T =", "  L =")) for line in lines):
        lines.append("  T = der(x)^2 + der(y)^2 + sum(der(q[i])^2, i in 1:2);")
    lines.append("end M;")
    return "\n".join(lines) + "\n"


@pytest.mark.slow
@SETTINGS
@given(grammar_models())
def test_grammar_models_raise_only_lag_errors(text):
    check(text)


# -- (d) random mechanics: valid structure, random energies, constraints and forces --------------------
MECHANICS_LEAVES = st.sampled_from(["x", "y", "der(x)", "der(y)", "t", "m", "1", "2", "0", "0.5"])


@functools.cache
def mechanics_expressions():
    def extend(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "^"]), inner).map(lambda p: f"({p[0]} {p[1]} {p[2]})"),
            st.tuples(st.sampled_from(["sin", "cos", "exp", "log", "sqrt", "abs", "sign", "tan", "atan", "asin",
                                       "cosh"]), inner).map(lambda p: f"{p[0]}({p[1]})"),
            st.tuples(st.sampled_from(["min", "max", "atan2"]), inner, inner).map(lambda p: f"{p[0]}({p[1]}, {p[2]})"),
        )

    return st.recursive(MECHANICS_LEAVES, extend, max_leaves=6)


@st.composite
def mechanics_models(draw) -> str:
    expression = mechanics_expressions()
    lines = ["model M", "  parameter m = 1.5;", "  coordinate x(start = 0.3);", "  coordinate y(start = 0.7);"]
    if draw(st.booleans()):
        lines.append(f"  T = der(x)^2*({draw(expression)}) + der(y)^2 + {draw(expression)};")
        if draw(st.booleans()):
            lines.append(f"  U = {draw(expression)};")
    else:
        lines.append(f"  L = {draw(expression)} + {draw(expression)};")
    for k in range(draw(st.integers(0, 2))):
        lines.append(f"  constraint c{k}: {draw(expression)} = {draw(expression)};")
    if draw(st.booleans()):
        lines.append(f"  force x = {draw(expression)};")
    if draw(st.booleans()):
        lines.append(f"  dissipation = {draw(expression)};")
    lines.append("end M;")
    return "\n".join(lines) + "\n"


@pytest.mark.slow
@SETTINGS
@given(mechanics_models())
def test_mechanics_models_raise_only_lag_errors(text):
    check(text)
