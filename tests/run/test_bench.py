"""lagc bench: the ladders, the CSV header, the cached reference, and the error it reports
checked against the closed-form solution of the Kepler problem at whole periods."""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

import lagdsl
from lagdsl import bench, reference
from lagdsl.cli import main
from lagdsl.run import toolchain
from lagdsl.scene import Overrides
from tests.conftest import library_model, model_file, own_cache

# The Kepler ellipse of models/kepler.lag (r0 = 1, r0' = 0, theta0' = 1.2, GM = 1): energy
# E = 1.44/2 - 1 = -0.28, semi-major axis a = -1/(2E), period T = 2 pi a^(3/2). At t = kT the
# satellite is back at r = 1, theta = 2 pi k.
ENERGY = 1.2 ** 2 / 2 - 1
PERIOD = 2 * math.pi * (-1 / (2 * ENERGY)) ** 1.5
ORBITS = 3
KEPLER = f"""model Kepler
  coordinate r(start = 1.0);
  coordinate theta(start = 0, velocity = 1.2);
  T = (der(r)^2 + r^2*der(theta)^2)/2;
  U = -1/r;
  scene periods
    time(stop = {ORBITS * PERIOD!r}, interval = {PERIOD!r});
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output r, theta;
  end periods;
end Kepler;
"""


@pytest.fixture
def kepler():
    return model_file(KEPLER, "kepler")


def test_adaptive_ladder_spans_1e_3_to_1e_13_with_atol_scaled():
    settings = bench.adaptive_ladder("dop853", "c", 0.01)
    assert [s.rtol for s in settings] == [float(f"1e-{k}") for k in range(3, 14)]
    # exact decimals: 1e-4 * 0.01 would be 1.0000000000000002e-06
    assert [s.atol for s in settings] == [float(f"1e-{k}") for k in range(5, 16)]
    assert all(s.step is None for s in settings)


def test_the_table_follows_each_ladder_and_writes_its_settings_as_decimals():
    """Within a method the rows go along the ladder, loosest first, whatever the times (noise in
    them scrambled the order); the CSV writes 1e-06, not 9.9999999999999995e-07."""
    settings = bench.adaptive_ladder("dop853", "c", 0.01)[:4]
    times = (3e-5, 1e-5, 4e-5, 2e-5)
    rows = tuple(bench.BenchRow(s, seconds, 10, 10, 0, 1e-6, 1e-15) for s, seconds in zip(reversed(settings), times))
    accurate = reference.Reference(np.zeros(1), ("x",), np.zeros((1, 1)), 1e-15, "dop853", "float128", 1e-20,
                                   1e-22, 1.0, True)
    report = bench.BenchReport("Kepler", "ellipse", accurate, rows)
    assert [row.setting.rtol for row in report.sorted_rows()] == [1e-3, 1e-4, 1e-5, 1e-6]
    table = report.render().splitlines()[4:]
    assert [line.split()[2:4] for line in table] == [["0.001", "1e-05"], ["0.0001", "1e-06"], ["1e-05", "1e-07"],
                                                     ["1e-06", "1e-08"]]
    assert report.csv().splitlines()[2].startswith("dop853,c,0.0001,1e-06,,")


def test_step_ladder_halves_from_four_intervals_within_the_run_and_the_step_limit(kepler):
    plan = lagdsl.load(kepler).plan(None, Overrides(stop=1.0, interval=0.1))
    steps = [s.step for s in bench.step_ladder("rk4", "c", plan)]
    assert steps == [0.4, 0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625, 0.003125, 0.0015625]     # exact decimals
    short = lagdsl.load(kepler).plan(None, Overrides(stop=0.3, interval=0.1))
    assert max(s.step for s in bench.step_ladder("gauss", "c", short)) == pytest.approx(0.2)


def test_the_reference_is_cached_and_not_rebuilt(kepler, tmp_path, monkeypatch):
    own_cache(monkeypatch, tmp_path / "cache")      # cold: the first reference is built
    model = lagdsl.load(kepler)
    plan = model.plan()
    first = reference.reference_solution(model.equations, plan, model.source.name)
    monkeypatch.setattr(reference, "shared_library", lambda *a, **k: pytest.fail("rebuilt the reference"))
    second = reference.reference_solution(model.equations, plan, model.source.name)
    assert not first.cached and second.cached
    assert np.array_equal(first.values, second.values) and first.accuracy == second.accuracy
    assert first.precision == toolchain.extended_precision(toolchain.find_compiler())
    assert 0 < first.accuracy < 1e-13
    exact = np.column_stack([np.ones(ORBITS + 1), 2 * math.pi * np.arange(ORBITS + 1)])
    assert np.max(np.abs(first.values - exact)) < 1e-12


@pytest.mark.slow
def test_each_reported_error_is_within_2x_of_the_true_error(kepler):
    """The true error of each setting, rerun as `lagc run` would, against the closed form."""
    model = lagdsl.load(kepler)
    report = bench.run_bench(model, integrators=("dop853", "rk4"), repeat=1)
    exact = np.column_stack([np.ones(ORBITS + 1), 2 * math.pi * np.arange(ORBITS + 1)])
    checked = 0
    for row in report.rows:
        s = row.setting
        if row.failure is not None:     # rk4 with a step of two orbits
            continue
        result = model.simulate(integrator=s.integrator, rtol=s.rtol, atol=s.atol, step=s.step)
        true_error = float(np.max(np.abs(result.values - exact)))
        if true_error < 100 * report.reference.accuracy:
            continue
        assert row.error / 2 <= true_error <= 2 * row.error, (s, row.error, true_error)
        checked += 1
    assert checked >= 12


@pytest.mark.slow
def test_csv_has_exactly_the_documented_header(kepler, tmp_path, capsys):
    table = tmp_path / "table.csv"
    assert main(["bench", str(kepler), "--integrators", "gauss", "--repeat", "1", "-o", str(table)]) == 0
    lines = table.read_text().splitlines()
    assert lines[0] == "integrator,backend,rtol,atol,step,seconds,rhs_evals,steps,rejected,error,reference_error"
    fields = lines[1].split(",")
    assert fields[:2] == ["gauss", "c"] and fields[2] == fields[3] == fields[8] == ""
    assert "reference: taylor" in capsys.readouterr().out


@pytest.mark.parametrize("options, message", [
    (["--backend", "fortran"], "lagc: error: --backend: expected c, numpy or both, got 'fortran'"),
    (["--repeat", "two"], "lagc: error: --repeat: expected a whole number >= 1, got 'two'"),
    (["--integrators", "dop853,rk5"], "lagc: error: --integrators: unknown integrator 'rk5'"),
])
def test_bad_options_are_clean_errors(kepler, options, message, capsys):
    assert main(["bench", str(kepler), *options]) == 1
    assert capsys.readouterr().err.startswith(message)


def test_simulate_estimates_its_global_error(kepler, monkeypatch):
    """A rerun at 100x tighter tolerances, unless the reference is cached already (which an
    earlier test in the same worker may have done): this test takes the rerun's branch."""
    monkeypatch.setattr(reference, "reference_is_cached", lambda *arguments: False)
    model = lagdsl.load(kepler)
    result = model.simulate(estimate_error=True)
    exact = np.column_stack([np.ones(ORBITS + 1), 2 * math.pi * np.arange(ORBITS + 1)])
    true_error = float(np.max(np.abs(result.values - exact)))
    estimate = result.summary.error
    assert true_error / 2 <= float(estimate) <= 2 * true_error and estimate.seconds >= 0
    assert "rerun at rtol = 1e-12" in estimate.against
    assert "estimated global error" in result.summary.render()
    assert model.simulate().summary.error is None
    errors = dict(estimate.columns)                          # per column: here r and theta
    assert list(errors) == ["r", "theta"] and max(errors.values()) == estimate.value
    assert estimate.column == max(errors, key=errors.get)


def test_the_error_names_its_column_and_unit():
    """Columns of different units: the largest error is named with its column and unit, and each
    column's largest error is listed in its unit."""
    estimate = library_model("kepler").simulate(stop=5.0, estimate_error=True).summary.error
    errors = dict(estimate.columns)
    units = dict(zip(errors, estimate.units))
    assert units == {"r": "m", "theta": "rad", "energy": "J", "momentum(theta)": "kg*m^2/s"}
    shown = estimate.render()
    assert shown.startswith(f"estimated global error: {estimate.value:.2g} {units[estimate.column]} in "
                            f"{estimate.column} (")
    assert shown.splitlines()[1] == "  per column: " + ", ".join(
        f"{name} {error:.2g} {units[name]}" for name, error in errors.items())


def test_run_error_and_plot(kepler, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    picture = tmp_path / "outputs.png"
    assert main(["run", str(kepler), "--error", "--rtol", "1e-14", "--plot", str(picture), "-o",
                 str(tmp_path / "out.csv")]) == 0
    assert "against the __float128 reference" in capsys.readouterr().err or \
        toolchain.extended_precision(toolchain.find_compiler()) != "float128"
    assert picture.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("command, status", [("run", 1), ("bench", 1), ("modes", 2)])     # modes: 2 for bad input
def test_a_plot_without_matplotlib_is_refused_before_the_work_naming_the_extra(kepler, tmp_path, capsys, monkeypatch,
                                                                                command, status):
    monkeypatch.setitem(sys.modules, "matplotlib", None)      # `import matplotlib` fails as when it is not installed
    picture, table = tmp_path / "figure.png", tmp_path / "table.csv"
    assert main([command, str(kepler), "--plot", str(picture), "-o", str(table)]) == status
    assert capsys.readouterr().err.startswith("lagc: error: --plot: drawing a plot needs matplotlib, which is not "
                                              "installed: pip install 'lagdsl[plots]'")
    assert not picture.exists() and not table.exists()
