"""The command line end to end: exit codes, output formats, no output file on failure."""
from __future__ import annotations

import contextlib
import io
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path

import pytest

from lagdsl.cli import main
from lagdsl.progress import TimeProgress
from tests.conftest import MODELS, compiled, lagc_in_process, model_file
from tests.run.test_bounds import OSCILLATOR


def lagc(*arguments, cwd=None):
    """`lagc` run in this process (in `cwd` if given): no interpreter to start for each command."""
    with contextlib.chdir(cwd or os.getcwd()):
        return lagc_in_process(*arguments)


def test_check_reports_the_double_pendulum():
    """The console script itself, in a process of its own: `python -m lagdsl`."""
    done = subprocess.run([sys.executable, "-m", "lagdsl", "check", MODELS / "double_pendulum.lag"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "degrees of freedom: 2" in done.stdout
    assert "rod1: holonomic, identically satisfied by the coordinates: dropped" in done.stdout
    assert "energy:" in done.stdout
    assert "chaos" in done.stdout


@pytest.mark.slow
def test_check_says_where_the_nystrom_integrator_applies():
    """rkn8 needs q'' = a(t, q): the Pleiades (Cartesian bodies) qualify, the double pendulum
    (M depends on the angles, so f holds the velocities squared) does not."""
    line = "accelerations: independent of the velocities, q'' = a(t, q): the Nystrom integrator rkn8 applies"
    assert line in lagc("check", MODELS / "pleiades.lag").stdout
    assert "accelerations:" not in lagc("check", MODELS / "double_pendulum.lag").stdout


@pytest.mark.slow
def test_eom_prints_text_and_latex():
    text = lagc("eom", MODELS / "double_pendulum.lag")
    assert text.returncode == 0
    assert "cos(theta1 - theta2)" in text.stdout and "theta2''" in text.stdout
    latex = lagc("eom", "--latex", MODELS / "double_pendulum.lag")
    assert latex.stdout.startswith("\\begin{aligned}") and "\\ddot" in latex.stdout


def test_run_writes_csv_with_the_exact_header(tmp_path):
    out = tmp_path / "out.csv"
    done = lagc("run", MODELS / "rolling_penny.lag", "--stop", "0.1", "-o", out)
    assert done.returncode == 0, done.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == ("t,x,y,phi,theta,energy,momentum(theta),multiplier(roll_x),multiplier(roll_y),"
                        "residual(roll_x),residual(roll_y)")
    assert len(lines) == 1 + 11
    assert "steps accepted" in done.stderr and "largest constraint residual" in done.stderr


@pytest.mark.slow
def test_run_overrides():
    done = lagc("run", MODELS / "wedge.lag", "--set", "m=2", "--set", "s.velocity=1", "--stop", "0.1")
    assert done.returncode == 0, done.stderr
    first = done.stdout.splitlines()[1].split(",")
    assert float(first[4]) == 1.0             # der(s) at t = 0


def test_model_errors_exit_1_without_traceback(tmp_path):
    bad = tmp_path / "bad.lag"
    bad.write_text("model Bad\n  coordinate x;\n  T = m*der(x)^2;\nend Bad;\n")
    done = lagc("check", bad)
    assert done.returncode == 1
    assert f"{bad}:3:7: error: undefined name 'm'" in done.stderr
    assert "Traceback" not in done.stderr


def test_numerical_failure_names_time_state_and_remedy_and_keeps_the_rows(tmp_path):
    # T = r^2 r'^2 / 2: r^2 = 1 - 2t reaches 0 at t = 1/2, where the mass matrix r^2 is singular.
    model = model_file("model Collapse\n  coordinate r(start = 1, velocity = -1);\n"
                       "  T = r^2*der(r)^2/2;\nend Collapse;\n", "collapse")
    out = tmp_path / "out.csv"
    done = lagc("run", model, "--stop", "1", "-o", out)
    assert done.returncode == 1
    assert "lagc: error: simulation failed at t = 0.4" in done.stderr or \
        "lagc: error: simulation failed at t = 0.5" in done.stderr
    assert "state: r = " in done.stderr and "remedy:" in done.stderr
    assert "Traceback" not in done.stderr
    lines = out.read_text().splitlines()                 # the rows before the failure, a valid CSV
    assert lines[0] == "t,r" and 2 <= len(lines) <= 52 and [float(x) for x in lines[1].split(",")] == [0, 1]
    assert "the run is incomplete: it stopped at t = 0.4" in done.stderr or \
        "the run is incomplete: it stopped at t = 0.5" in done.stderr


@pytest.mark.parametrize("language", ["c", pytest.param("numpy", marks=pytest.mark.slow)])
def test_emit_writes_source(tmp_path, language):
    out = tmp_path / ("model.c" if language == "c" else "model.py")
    done = lagc(MODELS / "kepler.lag", "--emit", language, "-o", out)
    assert done.returncode == 0, done.stderr
    assert "Kepler" in out.read_text()


@pytest.mark.parametrize("options, version, kind, other, entry", [
    pytest.param(("--kind", "cs"), "2.0", "CoSimulation", "ModelExchange", "modelDescription.xml",
                 marks=pytest.mark.slow),
    (("--fmi", "3", "--kind", "me"), "3.0", "ModelExchange", "CoSimulation", "sources/buildDescription.xml")])
def test_emit_fmu_writes_an_fmi_archive(tmp_path, options, version, kind, other, entry):
    out = tmp_path / "Kepler.fmu"
    done = lagc(MODELS / "kepler.lag", "--emit", "fmu", *options, "-o", out)
    assert done.returncode == 0, done.stderr
    with zipfile.ZipFile(out) as archive:
        names = archive.namelist()
        description = archive.read("modelDescription.xml").decode()
    assert entry in names and any(name.startswith("binaries/") for name in names)
    assert f'fmiVersion="{version}"' in description and f"<{kind}" in description and f"<{other}" not in description


@pytest.mark.parametrize("arguments, message", [
    (("--emit", "fmu"), "error: -o: an FMU is a zip archive"),
    (("--emit", "c", "--kind", "me"), "error: --kind: an option of --emit fmu only"),
    (("--emit", "fmu", "--fmi", "4", "-o", "x.fmu"), "error: --fmi: FMI version 4: lagc exports 2.0 and 3.0 (--fmi 2 or 3)")])
def test_emit_fmu_refuses_what_it_cannot_do(tmp_path, arguments, message):
    done = lagc(MODELS / "kepler.lag", *arguments, cwd=tmp_path)
    assert done.returncode == 1 and message in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.fmu").exists()


# ---- bounded, interruptible runs; checked inputs (tests/run/test_bounds.py has the API side) ----

@pytest.fixture
def oscillator():
    return model_file(OSCILLATOR, "oscillator")


@pytest.mark.parametrize("arguments, words", [
    (["--stop", "inf"], "lagc: error: the stop time must be a finite number, not inf"),
    (["--set", "k=nan"], "lagc: error: cannot set 'k' to nan: values must be finite numbers"),
    (["--interval", "1e-300"], "would have 1e+300 rows, more than the limit of 1e+07; choose a larger --interval"),
    (["--max-step", "-1"], "lagc: error: --max-step: dop853(max_step = ...) must be a finite number > 0"),
    (["--atol", "nan"], "lagc: error: --atol: dop853(atol = ...) must be a finite number >= 0"),
])
def test_run_refuses_bad_inputs(oscillator, arguments, words):
    done = lagc("run", oscillator, *arguments)
    assert done.returncode == 1 and words in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("arguments, words", [
    (["sweep", "{model}", "--vary", "k=1:2:3"], "lagc: error: the following arguments are required: -o/--output"),
    (["run", "{model}", "--rtol", "abc"], "lagc: error: argument --rtol: invalid float value: 'abc'"),
    (["frobnicate"], "lagc: error: argument COMMAND: invalid choice: 'frobnicate'"),
])
def test_usage_errors_begin_as_every_error_and_exit_1(oscillator, arguments, words):
    """docs/language.md: an error in the settings exits 1; every message not about a place in a
    model file begins `lagc: error:`, argparse's usage errors too (they were `lagc sweep: error:`
    and exit 2)."""
    done = lagc(*(str(oscillator) if a == "{model}" else a for a in arguments))
    assert done.returncode == 1 and done.stderr.startswith("usage: lagc")
    assert done.stderr.splitlines()[-1].startswith(words), done.stderr


def test_every_error_line_begins_the_same_way(oscillator):
    for arguments in (["--stop", "inf"], ["--set", "nosuch=1"], ["--max-step", "-1"], ["-o", "/nonexistent/x.csv"]):
        done = lagc("run", oscillator, *arguments)
        errors = [line for line in done.stderr.splitlines() if "error" in line]
        assert done.returncode == 1 and errors and all(line.startswith("lagc: error: ") for line in errors), \
            done.stderr


def test_run_raises_a_tiny_rtol_with_one_warning(oscillator):
    done = lagc("run", oscillator, "--rtol", "1e-300")
    assert done.returncode == 0, done.stderr
    assert [line for line in done.stderr.splitlines() if "warning" in line] == [
        "lagc: warning: rtol = 1e-300 is below 10 eps; raised to 2.22e-15"]


def test_run_stops_at_the_step_limit(oscillator):
    done = lagc("run", oscillator, "--stop", "100", "--max-steps", "10")
    assert done.returncode == 1
    assert "steps accepted" in done.stderr and "the step limit of 10 steps was reached" in done.stderr
    assert "remedy: raise --max-steps" in done.stderr


def _wait_for_the_library(process, cache) -> bool:
    """True once the process has loaded a compiled model from `cache` (Linux: /proc/PID/maps):
    then the integration runs, and Ctrl-C reaches it rather than the compiler."""
    maps = Path(f"/proc/{process.pid}/maps")
    return _poll(process, lambda: str(cache) in maps.read_text())


def _cpu_seconds(process) -> float:
    """The CPU time the process has used (Linux: utime + stime in /proc/PID/stat)."""
    fields = Path(f"/proc/{process.pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wait_for_cpu(process, seconds: float) -> bool:
    """True once the process has computed for `seconds` more of CPU time: a run that has made
    progress, however loaded the machine (a wall-clock delay is not)."""
    start = _cpu_seconds(process)
    return _poll(process, lambda: _cpu_seconds(process) >= start + seconds)


def _poll(process, condition) -> bool:
    """Wait for `condition` while the process runs (two minutes at most)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if condition():
            return True
        time.sleep(0.05)
    return False


def _assert_valid_partial_csv(text: str, columns: str) -> list[list[float]]:
    lines = text.splitlines()
    assert lines[0] == columns
    rows = [[float(x) for x in line.split(",")] for line in lines[1:]]
    assert rows and all(len(row) == len(columns.split(",")) for row in rows)
    assert all(b[0] > a[0] for a, b in zip(rows, rows[1:]))
    return rows


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc to see the run start")
def test_ctrl_c_stops_lagc_run_with_the_rows_so_far(oscillator, tmp_path):
    cache = os.environ["LAGDSL_CACHE"]      # the suite's: the oscillator's library is built once, not in each run
    out = tmp_path / "out.csv"
    process = subprocess.Popen([sys.executable, "-m", "lagdsl", "run", str(oscillator), "--stop", "1e7",
                                "--interval", "10", "--rtol", "1e-13", "--max-steps", "1000000000000", "-o", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert _wait_for_the_library(process, cache) and _wait_for_cpu(process, 0.3)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr and "steps accepted" in stderr
    assert re.search(r"lagc: interrupted at t = [0-9.e+]+, after \d+ rows", stderr)
    rows = _assert_valid_partial_csv(out.read_text(), "t,x,energy")
    assert 1 < len(rows) < 1000001


def _standalone(oscillator, tmp_path) -> Path:
    cc = shutil.which("cc") or pytest.skip("no C compiler")
    source, program = tmp_path / "oscillator.c", tmp_path / "oscillator"
    assert lagc(oscillator, "--emit", "c", "-o", source).returncode == 0
    compiled([cc, "-std=c99", "-O2", "-o", program, source, "-lm"], check=True)
    return program


def test_the_standalone_program_checks_its_arguments(oscillator, tmp_path):
    program = _standalone(oscillator, tmp_path)
    for argument, words in [("--rtol=-1", "--rtol must be a finite number >= 0"),
                            ("--atol=nan", "--atol must be a finite number >= 0"),
                            ("--max_step=-1", "--max-step must be a finite number > 0"),
                            ("--max-steps=0.5", "--max-steps must be a whole number"),
                            ("t.stop=inf", "must be finite numbers"),
                            ("t.interval=1e-300", "more than the limit of 10000000"),
                            ("k=inf", "the parameter k is inf"),
                            ("m=1e-320", "the parameter w is inf"),
                            ("x.start=nan", "the initial value of x is nan")]:
        done = subprocess.run([program, argument], capture_output=True, text=True, timeout=30)
        assert done.returncode == 2 and words in done.stderr, (argument, done.stderr)
    warned = subprocess.run([program, "--rtol=1e-300"], capture_output=True, text=True, timeout=30)
    assert warned.returncode == 0 and "warning: rtol = 1e-300 is below 10 eps" in warned.stderr
    limited = subprocess.run([program, "t.stop=100", "--max-steps=10"], capture_output=True, text=True, timeout=30)
    assert limited.returncode == 1 and "the step limit of 10 steps was reached" in limited.stderr
    for argument, words in [("rtol=1e-12", "'rtol' is an option of the integrator: write --rtol=1e-12"),
                            ("k=0x10", "k: expected a plain number (the model declares no unit for it), got '0x10'"),
                            ("k=", "expected NAME=VALUE with a number (and a unit), got 'k='"),
                            ("--k=1", "unknown option '--k'")]:
        done = subprocess.run([program, argument], capture_output=True, text=True, timeout=30)
        assert done.returncode == 2 and words in done.stderr, (argument, done.stderr)
    helped = subprocess.run([program, "--help"], capture_output=True, text=True, timeout=30)
    assert helped.returncode == 0 and "--rtol" in helped.stdout and "NAME is a parameter [in its declared unit]: m k w" in helped.stdout
    grid = subprocess.run([program, "t.interval=0.3"], capture_output=True, text=True, timeout=30)
    times = [row[0] for row in _assert_valid_partial_csv(grid.stdout, "t,x,energy")]
    assert times == pytest.approx([0.0, 0.3, 0.6, 0.9, 1.0], abs=1e-15) and times[-1] == 1.0


def test_a_parameter_named_like_an_option_does_not_shadow_it(tmp_path):
    """Options have a syntax of their own (--rtol=...): `rtol=` sets the parameter rtol, in the
    program as in `lagc run --set`, and the summary says the tolerance the run used."""
    model = model_file(OSCILLATOR.replace("parameter k = 1.0;", "parameter k = 1.0;\n  parameter rtol = 1.0;")
                       .replace("U = k/2*x^2;", "U = rtol*k/2*x^2;"), "shadow")
    program = _standalone(model, tmp_path)
    done = subprocess.run([program, "rtol=4", "--rtol=1e-12"], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    assert "rtol = 1e-12" in done.stderr
    x = [row[1] for row in _assert_valid_partial_csv(done.stdout, "t,x,energy")]
    assert x[-1] == pytest.approx(math.cos(2.0), abs=1e-9)          # k_eff = 4: w = 2
    api = lagc("run", model, "--set", "rtol=4", "--rtol", "1e-12")
    assert api.returncode == 0 and float(api.stdout.splitlines()[-1].split(",")[1]) == pytest.approx(x[-1], abs=1e-12)


def test_ctrl_c_stops_the_standalone_program_with_a_valid_csv(oscillator, tmp_path):
    program = _standalone(oscillator, tmp_path)
    process = subprocess.Popen([program, "t.stop=5e7", "t.interval=10", "--rtol=1e-13", "--max-steps=1e15"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines, enough = [], threading.Event()

    def read_rows():            # the header and 100 rows, then Ctrl-C; the rest until the end
        for line in process.stdout:
            lines.append(line)
            if len(lines) > 100:
                enough.set()
        enough.set()

    reader = threading.Thread(target=read_rows, daemon=True)
    reader.start()
    assert enough.wait(120)
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)
    reader.join(30)
    stdout, stderr = "".join(lines), process.stderr.read()
    assert process.returncode == 130, stderr
    assert re.search(r"interrupted at t = [0-9.e+]+ after \d+ rows", stderr)
    rows = _assert_valid_partial_csv(stdout, "t,x,energy")
    assert 1 < len(rows) < 5000001


def test_the_progress_bar_shows_on_a_terminal_only_and_erases_itself(monkeypatch):
    """A run's bar appears once it has taken DELAY seconds, on a terminal, never on a log."""
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr("lagdsl.progress.DELAY", 0.0)
    terminal, log = Terminal(), io.StringIO()
    for stream in (terminal, log):
        progress = TimeProgress(stream, mininterval=0)
        progress(12.5, 0.0, 50.0)
        progress(13.0, 0.0, 50.0)
        progress.close()
    assert "t - t0 = 12.5 of 50" in terminal.getvalue()
    assert log.getvalue() == ""


def test_sigterm_stops_lagc_run_as_ctrl_c_does_keeping_the_rows(oscillator, tmp_path, capsys, monkeypatch):
    """`kill` (a batch system's time limit) ends the run with the rows computed so far, exit 143.
    The signal is sent once the run has passed t = 1000 (its progress report says so)."""
    class KillAfterTime:
        def __init__(self):
            self.sent = False

        def __call__(self, t, start, stop):
            if t > 1000 and not self.sent:
                self.sent = True
                os.kill(os.getpid(), signal.SIGTERM)

        def close(self):
            pass

    monkeypatch.setattr("lagdsl.cli.simulate.TimeProgress", KillAfterTime)
    out = tmp_path / "out.csv"
    status = main(["run", str(oscillator), "--stop", "1e7", "--interval", "10", "--rtol", "1e-13",
                   "--max-steps", "1000000000000", "-o", str(out)])
    stderr = capsys.readouterr().err
    assert status == 143, stderr
    assert re.search(r"lagc: interrupted at t = [0-9.e+]+, after \d+ rows", stderr)
    rows = _assert_valid_partial_csv(out.read_text(), "t,x,energy")
    assert rows[-1][0] >= 1000 and len(rows) > 100
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL      # lagc's handler is gone after it


def test_a_slow_stage_says_what_it_is_doing(monkeypatch):
    """A stage without a progress bar (deriving, compiling) says what it does once it has taken
    NOTICE seconds; the event here is the note itself, with NOTICE set to nothing."""
    import io
    import threading

    from lagdsl import progress
    monkeypatch.setattr(progress, "NOTICE", 0.0)
    stream, said = io.StringIO(), threading.Event()
    original = stream.write
    monkeypatch.setattr(stream, "write", lambda text: (original(text), said.set())[0])
    with progress.slow_stage("deriving the equations of motion", stream):
        assert said.wait(30)
    assert stream.getvalue() == "lagc: still deriving the equations of motion after 0 s\n"
