"""Each integrator is one record (integrators/registry.py): a new record reaches every stage.

A toy method, rk4's sources under another name, is registered here and nowhere else: the command
line's help lists it, the settings check its options, a run reports its counters on both
backends, and the bench runs its ladder.
"""
from __future__ import annotations

import dataclasses

import pytest

import lagdsl
from lagdsl.bench import run_bench
from lagdsl.cli import main
from lagdsl.errors import LagError
from lagdsl.integrators import registry
from lagdsl.settings import Overrides
from tests.conftest import MODELS

MODEL = MODELS / "pendulum.lag"


@pytest.fixture
def toy():
    record = dataclasses.replace(registry.get("rk4"), name="toy4", title="the toy integrator toy4",
                                 description="a toy: rk4 under another name", source="rk4.c")
    registry.register(record)
    yield record
    registry.unregister("toy4")


def test_the_help_lists_a_new_record(toy, capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "toy4: a toy: rk4 under another name" in " ".join(capsys.readouterr().out.split())


def test_the_settings_check_a_new_record(toy):
    model = lagdsl.load(MODEL)
    with pytest.raises(LagError, match="toy4 is a fixed-step method and needs a step"):
        model.simulate(integrator="toy4")
    with pytest.raises(LagError, match="toy4 has no option 'rtol'"):
        model.simulate(integrator="toy4", step=0.01, rtol=1e-6)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_run_reports_the_counters_of_a_new_record(toy, backend):
    result = lagdsl.load(MODEL).simulate(integrator="toy4", step=0.01, stop=1.0, backend=backend)
    summary = result.summary
    assert summary.integrator == "toy4"
    assert [name for name, _ in summary.counters] == list(toy.counters)
    assert "toy4" in summary.render()


@pytest.mark.slow      # every integrator's ladder on both backends
def test_the_bench_runs_a_new_record(toy):
    model = lagdsl.load(MODEL)
    report = run_bench(model, None, Overrides(stop=1.0), repeat=1)
    ladders = {row.setting.integrator for row in report.rows}
    assert {"toy4", "rk4", "dop853"} <= ladders
    errors = {row.setting.step: row.error for row in report.rows if row.setting.integrator == "toy4"}
    assert errors == {row.setting.step: row.error for row in report.rows if row.setting.integrator == "rk4"}
