"""Dimensions given on the walk that builds the model: an expression built once per index (a sum's
body, an indexed let's) is checked once, with the index a plain number, and a sum over an empty
range does not hide the dimension of its body from the members that have one."""
from __future__ import annotations

import pytest

from lagdsl.errors import LagError
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile

CHAIN = """model Chain
  parameter n = 3;
  parameter m = 1 [kg];
  parameter k = 4 [N/m];
  coordinate x[n] [m];
  {lets}
  T = sum(m/2*der(x[i])^2, i in 1:n);
  U = {potential};
end Chain;
"""


def errors_of(lets: str, potential: str) -> list[tuple[int, int, str]]:
    with pytest.raises(LagError) as raised:
        model_from_source(SourceFile("chain.lag", CHAIN.format(lets=lets, potential=potential)))
    return [(d.span.line, d.span.column, d.message) for d in raised.value.diagnostics]


def test_a_mistake_in_a_sum_is_reported_once_not_once_per_term():
    assert errors_of("", "sum(k/2*x[i]^2 + m, i in 1:n)") == [
        (8, 24, "'m' has dimension mass but 'k/2*x[i]^2' has mass*length^2/time^2")]


def test_a_power_to_the_index_is_not_a_power_to_a_constant():
    assert errors_of("", "sum(k/2*x[i]^i, i in 1:n)") == [
        (8, 7, "U has dimension mass/time^2 but T has mass*length^2/time^2"),
        (8, 15, "'x[i]' has dimension length, so its exponent must be a constant number")]


def test_an_indexed_let_whose_first_member_sums_over_an_empty_range_is_checked_by_the_others():
    # s[1] sums nothing (0, of any dimension); s[2] and s[3] are lengths, so k*s is a force.
    lets = "let s[i] = sum(x[j], j in 1:i - 1), i in 1:n;"
    assert errors_of(lets, "sum(k*s[i], i in 1:n)") == [
        (8, 7, "U has dimension mass*length/time^2 but T has mass*length^2/time^2")]
    model_from_source(SourceFile("chain.lag", CHAIN.format(lets=lets, potential="sum(k*s[i]^2, i in 1:n)")))


def test_a_mistake_in_an_output_unit_is_reported_once_not_at_the_uses_of_the_output():
    text = CHAIN.format(lets="", potential="sum(k/2*x[i]^2, i in 1:n)").replace(
        "end Chain;", "  output a = k*x[1] [Nn];\n  output b = a/k [m];\nend Chain;")
    with pytest.raises(LagError) as raised:
        model_from_source(SourceFile("chain.lag", text))
    assert [(d.span.line, d.message.split(" (")[0]) for d in raised.value.diagnostics] == [(9, "unknown unit 'Nn'")]


def test_an_indexed_let_over_an_empty_range_has_no_members_and_is_not_checked():
    lets = "let s[i] = k*x[i] + m, i in 1:0;"
    model = model_from_source(SourceFile("chain.lag", CHAIN.format(lets=lets, potential="sum(k/2*x[i]^2, i in 1:n)")))
    assert not any(let.name.startswith("s[") for let in model.lets)
