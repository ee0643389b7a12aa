"""Small commands do only what they need: a warm `lagc check` prints its stored answer
(run/answers.py) without the pipeline, the command line imports no heavy package before a command
asks for it, and `lagc cache clear` empties the front end's helper directories too.

Each import check runs in a fresh process, where nothing is imported yet; the other checks, and
the cold call that stores what a warm one reads, run in this one (`cold`).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import astuple

import pytest

from lagdsl.run import cache
from tests.conftest import lagc_in_process
from tests.run.test_warm_run import SWING

HEAVY = ("sympy", "lark", "pint", "scipy", "matplotlib")
# Runs `lagc` (or nothing, without arguments) and prints the heavy packages it imported as JSON on the last line of stderr.
REPORTING_IMPORTS = f"""import json, sys
import lagdsl.cli
status = lagdsl.cli.main(sys.argv[1:]) if sys.argv[1:] else 0
print(json.dumps(sorted({{name.split(".")[0] for name in sys.modules}} & set({HEAVY!r}))), file=sys.stderr)
sys.exit(status)
"""


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def cold(*arguments) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of `lagc` in this process, whose cold call costs no imports."""
    return astuple(lagc_in_process(*arguments))


def lagc(*arguments) -> tuple[int, str, str, list[str]]:
    """Exit status, stdout, stderr without the report, and the heavy packages imported."""
    done = subprocess.run([sys.executable, "-c", REPORTING_IMPORTS, *map(str, arguments)], capture_output=True,
                          text=True)
    *said, report = done.stderr.splitlines(keepends=True)
    return done.returncode, done.stdout, "".join(said), json.loads(report)


def test_importing_the_command_line_imports_no_heavy_package():
    assert lagc()[3] == []


def test_a_warm_check_prints_the_stored_answer_without_the_pipeline(cache_dir, tmp_path):
    model = tmp_path / "swing.lag"
    model.write_text(SWING.replace("parameter a = 0.5 [rad];",      # c's unit is not known: a note on stderr
                                   "parameter a = 0.5 [rad];\n  parameter c = 2.0;\n  output z = c*theta;"))
    status, summary, notes = cold("check", model)
    assert status == 0 and "Swing" in summary and "note:" in notes
    assert len(list(cache_dir.glob("check-*.json"))) == 1
    assert lagc("check", model) == (0, summary, notes, [])


# The stored answers' keys and contents, in this process: what is imported is the warm check's subject above.
def test_an_edited_model_is_checked_again(cache_dir, tmp_path):
    model = tmp_path / "swing.lag"
    model.write_text(SWING)
    first = lagc_in_process("check", model).stdout
    model.write_text(SWING.replace("parameter m = 1.0 [kg];", "parameter m = 2.5 [kg];"))
    again = lagc_in_process("check", model)
    assert again.returncode == 0 and again.stdout != first
    assert len(list(cache_dir.glob("check-*.json"))) == 2


def test_a_model_with_an_error_stores_no_answer(cache_dir, tmp_path):
    model = tmp_path / "bad.lag"
    model.write_text(SWING.replace("U = m*g*y;", "U = m*g*z;"))
    for _ in range(2):
        status, summary, message = astuple(lagc_in_process("check", model))
        assert status == 1 and summary == "" and "error:" in message and "Traceback" not in message
    assert not list(cache_dir.glob("check-*.json"))


def test_cache_clear_removes_the_helper_directories(cache_dir, tmp_path):
    for name in cache.HELPERS:
        (cache.helper_directory(name) / "tables.cache").write_text("kept between processes")
    (cache_dir / "notes.txt").write_text("not ours")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("not ours either")
    cache.clear()
    assert sorted(os.listdir(cache_dir)) == ["notes.txt"]
    os.symlink(elsewhere, cache_dir / cache.HELPERS[0])      # a link in a helper's place: removed, not followed
    cache.clear()
    assert sorted(os.listdir(cache_dir)) == ["notes.txt"] and os.listdir(elsewhere) == ["keep.txt"]


@pytest.mark.parametrize("varied", ["theta.start=0.1:0.5:4", pytest.param("g=9:10:3", marks=pytest.mark.slow),
                                    pytest.param("a=0.1:0.5:4", marks=pytest.mark.slow)])
def test_a_warm_sweep_writes_the_same_table_without_the_pipeline(cache_dir, tmp_path, varied):
    """`a` gives the start values (a varied value other values are computed from) and `g` enters
    the parameter w: with those every member is planned by the full pipeline, warm or not."""
    model = tmp_path / "swing.lag"
    model.write_text(SWING)
    sweep = ("sweep", model, "--vary", varied, "--stop", "0.5")
    status, _, summary = cold(*sweep, "-o", tmp_path / "cold.csv")
    assert status == 0 and " ok, 0 failed" in summary
    status, _, again, imported = lagc(*sweep, "-o", tmp_path / "warm.csv")
    assert status == 0 and again.split(",")[:3] == summary.split(",")[:3]
    assert (tmp_path / "warm.csv").read_bytes() == (tmp_path / "cold.csv").read_bytes()
    assert ("sympy" in imported) == (varied[0] in "ag")


def test_a_warm_modes_says_the_same_without_the_pipeline(cache_dir, tmp_path):
    """The table, the CSV and the warning (the scene's start is no equilibrium) of the cold call."""
    model = tmp_path / "swing.lag"
    model.write_text(SWING)
    first = cold("modes", model, "-o", tmp_path / "cold.csv")
    assert first[0] == 0 and "not an equilibrium" in first[2]
    warm = lagc("modes", model, "-o", tmp_path / "warm.csv")
    assert warm == (*first, [])
    assert (tmp_path / "warm.csv").read_bytes() == (tmp_path / "cold.csv").read_bytes()
    found = lagc("modes", model, "--find")      # other options: computed again
    assert found[0] == 0 and "equilibrium" in found[2] and "sympy" in found[3]
