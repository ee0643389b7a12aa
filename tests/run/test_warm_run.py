"""A warm `lagc run` (a stored plan of the scene, run/plans.py): no sympy, no lark, the same bytes.

Each case runs `lagc` in fresh processes against a private cache, as users do: once to build,
then again warm; the CSV, the exit status and the standard error (but for the wall time of
the integration) must be those of a cold run (`--no-cache`).
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import pytest

from lagdsl.cli import common as cli
from lagdsl.cli import main
from tests.conftest import lagc_in_process, own_cache

SWING = """model Swing "a pendulum"
  parameter m = 1.0 [kg];
  parameter l = 1.0 [m];
  parameter g = 9.81 [m/s^2];
  parameter w = sqrt(g/l) [1/s]  "computed from g and l";
  parameter a = 0.5 [rad];
  coordinate theta(start = a, velocity = w/10) [rad];
  let x = l*sin(theta);
  let y = -l*cos(theta);
  T = m/2*(der(x)^2 + der(y)^2);
  U = m*g*y;
  scene swing
    time(stop = 1, interval = 0.25);
    integrator dop853(rtol = 1e-9, atol = 1e-12);
    output theta, energy;
  end swing;
end Swing;
"""
# Runs `lagc` and then writes the top-level packages of sympy and lark it imported to the file argv[1].
LAGC_REPORTING_IMPORTS = """import sys
from lagdsl.cli import main
status = main(sys.argv[2:])
with open(sys.argv[1], "w") as report:
    report.write(" ".join(sorted({name.split(".")[0] for name in sys.modules} & {"sympy", "lark"})))
sys.exit(status)
"""


@pytest.fixture
def model(tmp_path, monkeypatch):
    own_cache(monkeypatch, tmp_path / "cache")
    path = tmp_path / "swing.lag"
    path.write_text(SWING)
    return path


def lagc(*arguments) -> tuple[subprocess.CompletedProcess, str]:
    """The finished `lagc` process, and the heavy packages it imported ("lark sympy", "" when warm)."""
    report = os.environ["LAGDSL_CACHE"] + "-imports"
    done = subprocess.run([sys.executable, "-c", LAGC_REPORTING_IMPORTS, report, *map(str, arguments)],
                          capture_output=True, text=True)
    with open(report) as imported:
        return done, imported.read()


def lagc_here(capsys, *arguments) -> tuple[int, str, str]:
    """`lagc` in this process (sympy is imported already, so a cold run is cheap here)."""
    status = main(list(map(str, arguments)))
    out, err = capsys.readouterr()
    return status, out, without_wall_time(err)


@pytest.fixture
def pipeline_calls(monkeypatch) -> list:
    """The models `lagc` parses and derives in this process (none on a warm run)."""
    calls = []
    full_pipeline = cli.load_model
    monkeypatch.setattr(cli, "load_model", lambda source: calls.append(source.name) or full_pipeline(source))
    return calls


def without_wall_time(stderr: str) -> str:
    return re.sub(r", [0-9.e+-]+ s$", ", (time) s", stderr, flags=re.MULTILINE)


def assert_same_run(first: subprocess.CompletedProcess, second: subprocess.CompletedProcess) -> None:
    assert (first.returncode, first.stdout) == (second.returncode, second.stdout)
    assert without_wall_time(first.stderr) == without_wall_time(second.stderr)


def plan_entries(model) -> list:
    return sorted((model.parent / "cache").glob("plan-*.json"))


def replace_bytes(path, data: bytes) -> None:
    """Damage a cache entry as a new file: this process may have the old one mapped (a library)."""
    path.unlink()
    path.write_bytes(data)


@pytest.mark.parametrize("backend", ["c", pytest.param("numpy", marks=pytest.mark.slow)])
def test_a_warm_run_imports_neither_sympy_nor_lark_and_writes_the_same_bytes(model, backend, capsys):
    cold = lagc_here(capsys, "run", model, "--backend", backend)
    assert cold[0] == 0 and cold[1].startswith("t,theta,energy\n0,0.5,")
    assert len(plan_entries(model)) == 1
    warm, imported = lagc("run", model, "--backend", backend)
    assert imported == ""
    assert (warm.returncode, warm.stdout, without_wall_time(warm.stderr)) == cold


def test_a_warm_run_stops_where_the_scenes_condition_says(model, capsys):
    """The stop condition's text travels in the stored plan: the summary names it on a warm run."""
    ball = model.with_name("ball.lag")
    ball.write_text("model Ball\n  parameter g = 9.81;\n  coordinate y(start = 0, velocity = 4);\n"
                    "  T = der(y)^2/2;\n  U = g*y;\n  scene flight\n    time(stop = 10, interval = 0.1);\n"
                    "    stop when y < 0;\n    output y;\n  end flight;\nend Ball;\n")
    cold = lagc_here(capsys, "run", ball)
    assert "stopped at t = 0.815494393476" in cold[2] and "where y < 0" in cold[2]
    warm, imported = lagc("run", ball)
    assert imported == "" and (warm.returncode, warm.stdout, without_wall_time(warm.stderr)) == cold


@pytest.fixture(scope="module")
def primed(tmp_path_factory):
    """A model whose scene has been run once, so its plan is stored (shared: warm runs write nothing).
    Run in this process: the tests above show that a new process finds what it stores."""
    directory = tmp_path_factory.mktemp("primed")
    model = directory / "swing.lag"
    model.write_text(SWING)
    with pytest.MonkeyPatch.context() as patch:
        own_cache(patch, directory / "cache")
        assert lagc_in_process("run", model).returncode == 0
    return model


# Each case builds the program once more (--no-cache): the default run keeps a run with settings, a
# refused value and a numerical failure; the others are slow.
@pytest.mark.parametrize("arguments", [
    ["--set", "m=2", "--set", "theta.start=0.25", "--set", "theta.velocity=-1", "--stop", "0.5"],
    ["--set", "mass=2"],                                  # not a parameter: a suggestion
    ["--max-steps", "3"],                                 # a numerical failure, with partial rows
    *(pytest.param(arguments, marks=pytest.mark.slow) for arguments in [
        [],
        ["--rtol", "1e-7", "--atol", "1e-9", "--max-step", "0.1", "--interval", "0.1", "--start", "0.5"],
        ["--rtol", "1e-20"],                              # raised to the floor, with a warning
        ["--set", "theta.start=inf"],
        ["--set", "l"],
        ["--set", "thta.start=1"],
        ["--stop", "1e9"],                                # too many rows: located at the scene's time
        ["--interval", "1e-12"],
        ["--atol", "-1"],
        ["--step", "0.1"],                                # dop853 has none
    ]),
])
def test_warm_runs_give_the_cold_runs_output_and_errors(primed, arguments, capsys, pipeline_calls, monkeypatch):
    own_cache(monkeypatch, primed.parent / "cache")
    warm = lagc_here(capsys, "run", primed, *arguments)
    assert pipeline_calls == []
    assert lagc_here(capsys, "run", primed, "--no-cache", *arguments) == warm
    assert len(pipeline_calls) == 1


def test_the_located_error_of_a_warm_run_points_into_the_model(model, capsys, pipeline_calls):
    lagc_here(capsys, "run", model)
    status, _, error = lagc_here(capsys, "run", model, "--stop", "1e9")
    assert status == 1 and len(pipeline_calls) == 1
    assert error.startswith(f"{model}:13:5: error: the output grid from 0 to 1e+09 every 0.25")
    assert "    time(stop = 1, interval = 0.25);\n    ^~~~" in error


@pytest.mark.parametrize("name", [pytest.param("g", marks=pytest.mark.slow), "a"])
def test_setting_a_value_others_are_computed_from_takes_the_full_pipeline(model, name, capsys, pipeline_calls):
    lagc_here(capsys, "run", model)
    again = lagc_here(capsys, "run", model, "--set", f"{name}=0.3")
    assert len(pipeline_calls) == 2
    assert again == lagc_here(capsys, "run", model, "--no-cache", "--set", f"{name}=0.3")


@pytest.mark.slow
def test_another_scene_integrator_backend_or_text_is_not_warm(model, capsys, pipeline_calls):
    lagc_here(capsys, "run", model)
    lagc_here(capsys, "run", model, "--scene", "swing")          # asked for by name: another key
    lagc_here(capsys, "run", model, "--integrator", "dopri5")
    lagc_here(capsys, "run", model, "--backend", "numpy")
    model.write_text(SWING.replace("0.5 [rad]", "0.4 [rad]"))
    assert "\n0,0.40000000000000002," in lagc_here(capsys, "run", model)[1]
    assert len(pipeline_calls) == 5 and len(plan_entries(model)) == 5


@pytest.mark.parametrize("damage", ["plan", pytest.param("library", marks=pytest.mark.slow)])
def test_a_truncated_plan_or_library_is_rebuilt(model, damage, capsys):
    expected = lagc_here(capsys, "run", model)
    (plan,) = plan_entries(model)
    (library,) = (model.parent / "cache").glob("Swing_*.so")
    entry = plan if damage == "plan" else library
    replace_bytes(entry, entry.read_bytes()[:len(entry.read_bytes()) // 2])
    rebuilt, imported = lagc("run", model)
    assert imported == "lark sympy"
    assert (rebuilt.returncode, rebuilt.stdout, without_wall_time(rebuilt.stderr)) == expected
    assert json.loads(plan.read_text())["columns"] == ["theta", "energy"]
    warm, imported = lagc("run", model)
    assert imported == ""
    assert_same_run(rebuilt, warm)


@pytest.mark.slow
def test_no_cache_uses_and_leaves_nothing(model, capsys):
    stored = lagc_here(capsys, "run", model)
    cache = sorted(os.listdir(model.parent / "cache"))
    again, imported = lagc("run", model, "--no-cache")
    assert imported == "lark sympy" and sorted(os.listdir(model.parent / "cache")) == cache
    assert (again.returncode, again.stdout, without_wall_time(again.stderr)) == stored
    assert lagc_here(capsys, "run", model, "--no-cache", "--stop", "0.5")[0] == 0
    assert sorted(os.listdir(model.parent / "cache")) == cache


def test_cache_info_and_clear(model, capsys):
    cache = model.parent / "cache"
    lagc_here(capsys, "run", model)
    lagc_here(capsys, "run", model, "--backend", "numpy")
    (cache / "notes.txt").write_text("not ours")
    # the derived model (kept_models.py), and each backend's program, generated source and plan
    info = lagc_here(capsys, "cache", "info")[1]
    assert re.fullmatch(rf"build cache {re.escape(str(cache))}: 7 entries, [0-9.]+ MB\n", info)
    assert lagc_here(capsys, "cache", "clear")[1] == f"removed 7 entries from the build cache {cache}\n"
    assert os.listdir(cache) == ["notes.txt"]
    assert lagc_here(capsys, "cache", "info")[1] == f"build cache {cache}: 0 entries, 0.0 MB\n"
