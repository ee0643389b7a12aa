"""The standalone C program's batch mode: one member a line of standard input, one CSV with the
member's number first, equal row for row to single runs of the same program, serial or OpenMP."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from lagdsl.abi import parse_number
from lagdsl.run.toolchain import supports_openmp
from tests.run.c_harness import STRICT_FLAGS
from tests.conftest import compiled, model_file
from tests.run.test_failures import SINGULAR_LATER
from tests.test_cli import lagc


@pytest.fixture(scope="module")
def programs(tmp_path_factory) -> list[Path]:
    """SINGULAR_LATER's standalone program built with the strict flags, serial and (when the
    compiler can) with OpenMP: once for the module's tests, which only run it."""
    cc = shutil.which("cc") or pytest.skip("no C compiler")
    work = tmp_path_factory.mktemp("standalone")
    source = work / "model.c"
    assert lagc(model_file(SINGULAR_LATER, "singular"), "--emit", "c", "-o", source).returncode == 0
    builds = [("serial", [])] + ([("openmp", ["-fopenmp"])] if supports_openmp(cc) else [])
    for name, flags in builds:
        compiled([cc, *STRICT_FLAGS, *flags, "-o", work / name, source, "-lm"], check=True)
    return [work / name for name, _ in builds]


def test_the_standalone_batch_equals_single_runs_row_for_row(programs):
    """SINGULAR_LATER has x = x0 - t: its mass matrix is singular where x = 0."""
    members = ["x.start=1.3", "x.start=1.0", "x.start=2.7 y.velocity=0.5"]
    batch_input = "# x0 and y'0\n" + "\n\n".join(members) + "\n"
    for program in programs:
        done = subprocess.run([program, "--batch", "t.stop=1.5"], input=batch_input, capture_output=True,
                              text=True, timeout=30, env={**os.environ, "OMP_NUM_THREADS": "2"})
        assert done.returncode == 1, done.stderr
        lines = done.stdout.splitlines()
        assert lines[0] == "member,t,x,y"
        expected = []
        for b, member in enumerate(members):
            single = subprocess.run([program, "t.stop=1.5", *member.split()], capture_output=True, text=True,
                                    timeout=30)
            assert single.returncode == (1 if b == 1 else 0)
            expected += [f"{b},{row}" for row in single.stdout.splitlines()[1:]]
        assert lines[1:] == expected and sum(line.startswith("1,") for line in lines) == 4
        assert ("member 1: simulation failed at t = 0.875 after 4 rows: the mass matrix is singular"
                in done.stderr)
        assert "3 members, 1 failed" in done.stderr


@pytest.mark.slow
def test_a_bad_line_of_batch_input_stops_the_batch_before_it_runs(programs):
    program = programs[0]
    for text, words in [("x.start=1\nx.start=one\n", "line 2: expected NAME=VALUE with a number (and a unit), got 'x.start=one'"),
                        ("\nx.start=1 t.stop=3\n", "line 2: 't.stop' is not a parameter or a coordinate's"),
                        ("x.start=inf\n", "line 1: the initial value of x is inf"),
                        ("x.start=0x10\n", "line 1: x.start: expected a plain number (the model declares no unit for it), got '0x10'"),
                        ("x.start=1\nx.start=2\0y.start=1\n", "line 2: holds a NUL byte"),
                        ("x.start=1\n" + "y.start=1 " * 410 + "\n", "line 2: longer than 4095 characters")]:
        done = subprocess.run([program, "--batch"], input=text, capture_output=True, text=True, timeout=30)
        assert done.returncode == 2 and words in done.stderr and done.stdout == "", (text, done.stderr)


NUMBER_SAMPLES = ["1", "-0.5", "+2.", ".25", "1e-3", "1E+3", "inf", "-Infinity", "NaN", "0x10", "1_000", " 1",
                  "1 ", "", ".", "e5", "1e", "1.5.2", "infinit", "--1"]


def test_the_program_and_lagc_take_the_same_numbers(programs):
    """A value the standalone program refuses, `lagc run --set` refuses too (abi.NUMBER): both read
    plain decimal numbers, inf and nan; neither hexadecimal nor Python's underscores."""
    program = programs[0]
    for text in NUMBER_SAMPLES:
        done = subprocess.run([program, f"t.interval={text}", "--help"], capture_output=True, text=True, timeout=30)
        c_takes = "expected NAME=VALUE" not in done.stderr
        assert c_takes == (parse_number(text) is not None), (text, done.stderr)
