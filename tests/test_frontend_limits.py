"""Long and deeply nested input: it works, or it is a located LagError, never a RecursionError.

Sums and product chains of any length, parentheses and unary signs are walked iteratively; real
nesting (calls, powers, sums inside products) is limited to MAX_NESTING levels, which the
derivation, the common-subexpression elimination and both printers must handle.
"""
from __future__ import annotations

import math

import pytest
import sympy

import lagdsl
from lagdsl.errors import LagError
from lagdsl.frontend.expressions import MAX_NESTING, MAX_NUMBER_LENGTH
from lagdsl.mechanics import derive_equations
from lagdsl.pipeline import generate, model_from_source, plan
from lagdsl.scene import Overrides
from lagdsl.source import SourceFile
from tests.conftest import model_file


def oscillator(potential: str, kinetic: str = "der(x)^2/2") -> str:
    return f"""model Limits
  parameter a = 1;
  coordinate x(start = 0.5, velocity = 0.25);
  T = {kinetic};
  U = {potential};
end Limits;
"""


def potential_of(text: str) -> sympy.Expr:
    return model_from_source(SourceFile("limits.lag", text)).lagrangian.potential


def error_of(text: str) -> LagError:
    with pytest.raises(LagError) as caught:
        model_from_source(SourceFile("limits.lag", text))
    return caught.value


x = sympy.Symbol("x", real=True)
a = sympy.Symbol("a", real=True)


def test_sum_of_330_equal_terms():
    assert potential_of(oscillator(" + ".join(["a*x^2"] * 330))) == 330 * a * x**2


def test_sum_and_difference_of_400_distinct_terms_in_order():
    terms = " - ".join(f"x^{k}/{k}" for k in range(1, 401))
    expected = sympy.Add(*((1 if k == 1 else -1) * x**k / k for k in range(1, 401)))
    assert potential_of(oscillator(terms)) == expected


def test_product_chain_of_330_factors():
    assert potential_of(oscillator("*".join(["x"] * 330) + "/a/a")) == x**330 / a**2


def test_500_nested_parentheses():
    assert potential_of(oscillator("(" * 500 + "x^2" + ")" * 500)) == x**2


def test_500_and_501_unary_minuses():
    assert potential_of(oscillator("-" * 500 + "x")) == x
    assert potential_of(oscillator("- " * 501 + "x")) == -x


def test_signs_through_parentheses():
    assert potential_of(oscillator("a - (x - (a - -(x + a)))")) == 3*a
    assert potential_of(oscillator("x/(a/x)")) == x**2 / a


def test_division_by_zero_inside_a_divisor_is_still_found():
    error = error_of(oscillator("x/(a/0)"))
    assert "division by zero" in error.render()


def test_vector_sums_and_mixtures_are_checked_over_the_whole_chain():
    vectors = oscillator("dot({x, 0, 0} - -{0, x, 0} + ({0, 0, x}), {1, 1, 1})")
    assert potential_of(vectors) == 3 * x
    assert "cannot add a vector and a scalar" in error_of(oscillator("x + {x, x, x} - x")).render()
    assert "product of two vectors" in error_of(oscillator("norm(2*{x, 0, 0}*{0, x, 0})")).render()


def nested_sines(depth: int) -> str:
    return "sin(" * depth + "x" + ")" * depth


def test_nesting_at_the_limit_derives_and_prints_on_both_backends():
    """The deepest accepted expression goes through derivation, CSE and both printers."""
    source = SourceFile("limits.lag", oscillator(nested_sines(MAX_NESTING - 1)))
    model = model_from_source(source)
    equations = derive_equations(model)
    scene = plan(model, equations, None, Overrides())
    for backend in ("c", "numpy"):
        assert generate(equations, scene, backend, "limits.lag")[1].text


def test_nesting_beyond_the_limit_is_a_located_error():
    error = error_of(oscillator(nested_sines(MAX_NESTING)))
    (diagnostic,) = error.diagnostics
    assert f"nested more than {MAX_NESTING} levels" in diagnostic.message
    assert diagnostic.span.line == 5


def test_deep_horner_form_is_a_located_error_not_a_recursion_error():
    horner = "x"
    for _ in range(500):
        horner = f"({horner}*x + 1)"
    assert "nested more than" in error_of(oscillator(horner)).render()


def test_power_tower_beyond_the_limit_is_a_located_error():
    assert "nested more than" in error_of(oscillator("^".join(["x"] * 500))).render()


def test_long_number_literals():
    assert potential_of(oscillator("0." + "1" * (MAX_NUMBER_LENGTH - 2) + "*x")) != 0
    for literal in ("1" * 5000, "0." + "0" * 5000 + "1", "1e" + "0" * 5000 + "1"):
        error = error_of(oscillator(f"{literal}*x"))
        (diagnostic,) = error.diagnostics
        assert f"at most {MAX_NUMBER_LENGTH}" in diagnostic.message and diagnostic.span.column == 7


def test_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.lag"
    path.write_bytes("\ufeff".encode() + oscillator("x^2/2").encode())
    model = lagdsl.load(path)
    assert model.name == "Limits"


def long_sums_model(n: int = 330) -> str:
    """T and U each written as a sum of n terms, equal to der(x)^2/2 and (x - mean)^2/2 + c.

    T = Σ_k (cos²(kx) + sin²(kx)) x'²/n: the identity is not applied symbolically, so the
    derivation, CSE and printers see all n terms. U = Σ_k (x - k/1000)²/(2n) is a harmonic
    potential about the mean k/1000 = (n + 1)/2000 with ω = 1.
    """
    kinetic = " + ".join(f"{f}({k}*x)^2*der(x)^2/{n}" for k in range(1, n // 2 + 1) for f in ("cos", "sin"))
    potential = " + ".join(f"(x - {k}/1000)^2/{2 * n}" for k in range(1, n + 1))
    return f"""model LongSums
  coordinate x(start = 0.5, velocity = 0.25);
  T = {kinetic};
  U = {potential};
  scene s
    time(stop = 2, interval = 0.5);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
  end s;
end LongSums;
"""


@pytest.mark.slow
def test_330_term_sums_run_on_both_backends():
    model = lagdsl.load(model_file(long_sums_model(), "long"))    # its C built once, then cached
    mean = 331 / 2000
    for backend in ("c", "numpy"):
        result = model.simulate(backend=backend)
        exact = [mean + (0.5 - mean) * math.cos(t) + 0.25 * math.sin(t) for t in result.t]
        assert result["x"] == pytest.approx(exact, abs=1e-8)


def test_a_huge_power_of_a_parameter_is_evaluated_in_floating_point():
    """l^1e300 with l = 1/2 was computed exactly, digit by digit, for hours (fuzz): it is 0 in double
    precision, and l^(-400) is 2^400; an index n^1e300 is simply not an integer."""
    model = model_from_source(SourceFile("huge.lag", """model Huge
  parameter l = 0.5;
  parameter p = l^(-400);
  coordinate x(start = l^1e300, velocity = p*0);
  T = der(x)^2/2;
  U = x^2/2;
end Huge;
"""))
    assert model.parameters[1].value == 2.0 ** 400
    with pytest.raises(LagError, match="must be an integer"):
        model_from_source(SourceFile("index.lag", """model Index
  parameter n = 2;
  coordinate q[n^1e300];
  T = der(q[1])^2/2;
end Index;
"""))


TOWER = oscillator("x^2/2", "(2 + sin(exp(exp(exp(x + 2)))))*der(x)^2/2")


def let_chain(levels: int) -> str:
    """Lets that each use the one before twice: a_i = a_(i-1)^2 + sin(a_(i-1)), doubling in
    size when inlined and squaring in magnitude at every link."""
    lets = "\n".join(f"  let a{i} = a{i - 1}^2 + sin(a{i - 1});" for i in range(1, levels + 1))
    return (f"model Chain\n  coordinate x(start = 0.1);\n  let a0 = x;\n{lets}\n"
            f"  T = (2 + cos(a{levels}))*der(x)^2/2;\n  U = x^2/2;\nend Chain;\n")


# The default run takes `lagc eom` of the tower and `lagc check` of the lets; the other four are slow.
@pytest.mark.parametrize("text, command", [
    pytest.param(text, command, id=f"{name}-{command[0]}",
                 marks=() if (name, command[0]) in {("exponential tower", "eom"), ("24 doubling lets", "check")}
                 else pytest.mark.slow)
    for text, name in [(TOWER, "exponential tower"), (let_chain(24), "24 doubling lets")]
    for command in (["check"], ["eom"], ["emit"])])
def test_magnitudes_beyond_double_precision_end_the_identity_checks_and_the_display(tmp_path, text, command):
    """The 50-digit identity checks give up on sin of an argument of astronomical magnitude (the
    phase is unknown: never "zero") instead of computing pi to 1e30 bits; `lagc eom` sizes the
    inlined form without building it. Each command ends (it used to run for ever)."""
    import subprocess
    import sys
    path = tmp_path / "model.lag"
    path.write_text(text)
    arguments = [str(path), "--emit", "c"] if command == ["emit"] else [*command, str(path)]
    done = subprocess.run([sys.executable, "-m", "lagdsl", *arguments], capture_output=True, text=True,
                          timeout=300, env={**__import__("os").environ, "LAGDSL_CACHE": str(tmp_path / "cache")})
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr


def test_the_identity_probe_matches_double_precision_where_it_overflows():
    from lagdsl.calculus import Differentiator
    from lagdsl.mechanics.probe import Probe
    x = sympy.Symbol("x", real=True)
    probe = Probe(Differentiator((), (x,)), (x,))
    values = probe.evaluate([sympy.exp(1000 * x + 800), sympy.sin(sympy.exp(sympy.exp(x + 80))), sympy.sinh(-800 - x)])
    for exp_value, sin_value, sinh_value in values:
        assert exp_value == float("inf") and str(sin_value) == "nan" and sinh_value == float("-inf")
