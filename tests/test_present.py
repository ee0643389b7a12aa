"""`lagc eom`'s display: small expressions tidied, large ones shown through named intermediates."""
from __future__ import annotations

import re

import pytest
import sympy

from lagdsl.api import Model, load
from lagdsl.present import format_equations, tidy
from lagdsl.source import SourceFile
from tests.conftest import MODELS


def chain(n: int) -> Model:
    text = (MODELS / "pendulum_chain.lag").read_text(encoding="utf-8")
    text, count = re.subn(r"(parameter n = )\d+", rf"\g<1>{n}", text)
    assert count == 1
    return Model(SourceFile(f"pendulum_chain_{n}.lag", text))


@pytest.fixture(scope="module")
def chain12() -> Model:
    return chain(12)


def test_small_models_are_tidied_without_intermediates():
    shown = format_equations(load(MODELS / "double_pendulum.lag").equations)
    assert "l1*l2*m2*theta2''*cos(theta1 - theta2)" in shown
    assert "l1^2*theta1''*(m1 + m2)" in shown           # sin² + cos² = 1
    assert "where" not in shown and "der(" not in shown
    assert "a^2*m*theta''/4 = 0" in format_equations(load(MODELS / "rolling_penny.lag").equations)


def test_the_12_link_chain_is_shown_through_named_intermediates(chain12):
    lines = format_equations(chain12.equations).splitlines()
    where = lines.index("where")
    rows, definitions = lines[1:where], lines[where + 1:]
    assert [row.split(":")[0].strip() for row in rows] == [f"theta[{i}]" for i in range(1, 13)]
    assert all("theta[1]''" in row for row in rows)      # the mass matrix is full
    assert "12*l^2*m*theta[1]''" in rows[0] and "cos(theta[1] - theta[2])" in rows[0]
    defined = [line.strip().split(" = ")[0] for line in definitions]
    assert "der(der(x[12]))" in defined and "δL/δtheta[1]" in defined
    assert len(set(defined)) == len(defined)
    for k, line in enumerate(definitions):              # each defined after the ones it uses
        body = line.split(" = ", 1)[1]
        assert not any(name in body for name in defined[k:]), line
    used = " ".join(rows)
    assert all(name in used or any(name in d for d in definitions) for name in defined)


def test_the_12_link_chain_in_latex(chain12):
    shown = format_equations(chain12.equations, latex=True)
    assert shown.startswith("\\begin{aligned}") and shown.endswith("\\end{aligned}")
    assert "&\\text{where} \\\\" in shown
    assert "\\operatorname{der}(\\operatorname{der}(x_{12})) &= " in shown
    assert "\\delta L/\\delta \\theta_{1} &= " in shown


def test_tidy_leaves_alone_what_would_expand_into_too_many_terms():
    a, b, c, d, x = sympy.symbols("a b c d x")
    power = (a + b + c + d + sympy.sin(x)) ** 12
    assert tidy(power) == power
    assert tidy(a * sympy.sin(x) ** 2 + a * sympy.cos(x) ** 2) == a
