"""`lagc eom`'s display: small expressions tidied, large ones shown through the model's own names."""
from __future__ import annotations

import re

import pytest
import sympy

from lagdsl import present
from lagdsl.api import Model
from lagdsl.present import describe_model, format_equations
from lagdsl.source import SourceFile
from lagdsl.tidying import tidy
from lagdsl.typeset import latex_name
from tests.conftest import MODELS, library_model, without_units
from tests.mechanics.eom import symbols_of
from tests.models.support import gimbal_rows


def chain(n: int) -> Model:
    text = (MODELS / "pendulum_chain.lag").read_text(encoding="utf-8")
    text, count = re.subn(r"(parameter n = )\d+", rf"\g<1>{n}", text)
    assert count == 1
    return Model(SourceFile(f"pendulum_chain_{n}.lag", text))


@pytest.fixture(scope="module")
def chain12() -> Model:
    return chain(12)


@pytest.fixture(scope="module")
def chain6() -> Model:
    """Six links: with SHOW_LIMIT lowered, entries too large to write out as the 12 links' are, in
    a fifth of the time."""
    return chain(6)


def test_small_models_are_tidied_without_intermediates():
    shown = format_equations(library_model("double_pendulum").equations)
    assert "l1*l2*m2*theta2''*cos(theta1 - theta2)" in shown
    assert "l1^2*theta1''*(m1 + m2)" in shown           # sin² + cos² = 1
    assert "where" not in shown and "der(" not in shown
    assert "a^2*m*theta''/4 = 0" in format_equations(library_model("rolling_penny").equations)


def test_the_12_link_chain_reads_as_the_textbook(chain12):
    lines = format_equations(chain12.equations).splitlines()
    assert "where" not in lines
    rows = lines[1:]
    assert [row.split(":")[0].strip() for row in rows] == [f"theta[{i}]" for i in range(1, 13)]
    assert all("theta[1]''" in row for row in rows)      # the mass matrix is full
    assert "12*l^2*m*theta[1]''" in rows[0] and "cos(theta[1] - theta[2])" in rows[0]
    assert "-12*g*sin(theta[1])" in rows[0] and "11*l*theta[2]'^2*sin(theta[1] - theta[2])" in rows[0]


def test_entries_too_large_to_write_out_are_shown_through_the_models_own_names(chain6, monkeypatch):
    monkeypatch.setattr(present, "SHOW_LIMIT", 60)
    lines = format_equations(chain6.equations).splitlines()
    where = lines.index("where")
    rows, definitions = lines[1:where], lines[where + 1:]
    defined = [line.strip().split(" = ")[0] for line in definitions]
    assert "der(der(x[6]))" in defined and len(set(defined)) == len(defined)
    assert all(re.fullmatch(r"(der\()*[xy]\[\d+\]\)*", name) for name in defined), defined
    assert not re.search("[∂δ]|der̃", "\n".join(lines))        # the derivation's bookkeeping is inlined
    for k, line in enumerate(definitions):              # each defined after the ones it uses
        body = line.split(" = ", 1)[1]
        assert not any(name in body for name in defined[k:]), line
    used = " ".join(rows)
    assert all(name in used or any(name in d for d in definitions) for name in defined)


def test_the_named_intermediates_in_latex(chain6, monkeypatch):
    monkeypatch.setattr(present, "SHOW_LIMIT", 60)
    shown = format_equations(chain6.equations, latex=True)
    assert shown.startswith("\\begin{aligned}") and shown.endswith("\\end{aligned}")
    assert "&\\text{where} \\\\" in shown
    assert "\\ddot{x}_{6} &= " in shown and "\\ddot{\\theta}_{1}" in shown


LATEX_NAMES = """model Names
  parameter eps = 0.1;  parameter epsilon = 0.2;  parameter me = 2;  parameter m_rotor = 3;
  parameter Omega = 1;  parameter k = 4;
  coordinate theta1(start = 1);  coordinate x[2];
  let w = {der(theta1), 0, 0};
  T = me/2*der(theta1)^2 + m_rotor/2*(der(x[1])^2 + der(x[2])^2) + eps*w.x^2;
  U = -epsilon*cos(theta1)^2 + k/2*(x[1] - x[2] + Omega)^2;
end Names;
"""


def test_latex_writes_each_name_one_way_everywhere():
    """Greek names are their letters (eps and epsilon both varepsilon, but two quantities stay
    two: here eps is upright), other words upright,
    subscripts from digits, underscores and indices; parentheses stretch; no break after the
    last row."""
    shown = format_equations(Model(SourceFile("names.lag", LATEX_NAMES)).equations, latex=True)
    for name in ("\\varepsilon", "\\mathrm{eps}", "\\mathrm{me}", "m_{\\mathrm{rotor}}", "\\Omega",
                 "\\ddot{\\theta}_{1}", "\\ddot{x}_{2}", "x_{1}"):
        assert name in shown, name
    assert latex_name("eps") == latex_name("epsilon") == "\\varepsilon"      # alone, both are the letter
    assert not re.search(r"(?<!\\left)(?<!\\right)[()]", shown.replace("\\right)", "")), shown
    rows = shown.splitlines()
    assert rows[-1] == "\\end{aligned}" and not rows[-2].endswith("\\\\")
    assert all(row.endswith(" \\\\") for row in rows[1:-2])


def test_the_gimbal_gyroscope_is_three_short_rows():
    """Its rings' and rotor's angular velocities come from omega_body of rotation matrices; shown,
    the rows are the header's closed form: sin⁴ + 2 sin² cos² + cos⁴ reduced, zeros dropped."""
    equations = library_model("gimbal_gyroscope").equations
    lines = format_equations(equations).splitlines()
    assert len(lines) == 4 and all(len(line) < 180 for line in lines), lines     # 600 and more before
    display = present.Display(equations.calculus())
    s = symbols_of(equations)
    for (_, lhs, rhs), closed in zip(present.equation_rows(equations, display), gimbal_rows(s)):
        assert sympy.simplify(lhs - rhs - closed) == 0


def test_tidy_reduces_powers_of_sines_and_cosines():
    a, b, x, y = sympy.symbols("a b x y")
    s, c = sympy.sin(x), sympy.cos(x)
    assert tidy(a * s**4 + 2 * a * s**2 * c**2 + a * c**4) == a
    assert tidy(a - a * s**2 + b * s**2) == a * c**2 + b * s**2
    assert tidy(s**4 - c**4 - s**2 + c**2) == 0
    assert tidy(a * (s**2 + c**2) * (sympy.sin(y)**2 + sympy.cos(y)**2)) == a


def test_tidy_leaves_alone_what_would_expand_into_too_many_terms():
    a, b, c, d, x = sympy.symbols("a b c d x")
    power = (a + b + c + d + sympy.sin(x)) ** 12
    assert tidy(power) == power
    assert tidy(a * sympy.sin(x) ** 2 + a * sympy.cos(x) ** 2) == a


def mutated(name: str, old: str, new: str, units: bool = True) -> Model:
    """A library model with one change (`units=False`: without its units, which the change breaks)."""
    text = (MODELS / name).read_text(encoding="utf-8")
    assert old in text
    text = text if units else without_units(text)
    return Model(SourceFile(name, text.replace(old, new, 1)))


@pytest.mark.parametrize("exponent", ["1e-320", "4e9"])
def test_eom_of_a_kinetic_energy_with_an_extreme_exponent_is_shown_untidied(exponent):
    # Found by the fuzz campaign: tidying hung on 1/10^320 and ran out of memory on x^(4*10^9).
    model = mutated("driven_support.lag", "der(x)^2", f"der(x)^{exponent}", units=False)
    shown = format_equations(model.equations)
    assert shown.startswith("equations of motion of Kapitza") and "theta''" in shown


def test_tidy_leaves_alone_numbers_out_of_the_ordinary():
    a, b, x = sympy.symbols("a b x")
    pythagorean = sympy.sin(x) ** 2 + sympy.cos(x) ** 2
    for extreme in (sympy.Rational(1, 10**320) * pythagorean, 10**320 * a * pythagorean,
                    a ** sympy.Rational(1, 10**320) * pythagorean, (a + b) ** 4000000000,
                    (a + b) ** -4000000000, a ** 4000000000 * pythagorean):
        assert tidy(extreme) == extreme
    assert tidy(sympy.Rational(6626, 10**37) * a * pythagorean) == sympy.Rational(6626, 10**37) * a
    assert tidy(a ** 3 * (b + 1) ** -2 * pythagorean) == a ** 3 / (b + 1) ** 2      # a denominator stays whole


def test_check_shows_a_derived_unit_as_written_with_si_beside():
    model = Model(SourceFile("field.lag", """model Field
  parameter k = 40 [N/m];  parameter B = 2 [T];  parameter m = 1 [kg];
  coordinate x [m];
  T = m/2*der(x)^2;  U = k/2*x^2;
  output pull = k*x [N];
end Field;
"""))
    shown = describe_model(model.ir, model.equations)
    assert "parameters: k = 40 [N/m] (= kg/s^2), B = 2 [T] (= kg/(s^2*A)), m = 1 [kg]" in shown
    assert "outputs: pull [N]" in shown
