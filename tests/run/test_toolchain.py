"""Building a library: the portable flags are tried again only when the compiler refuses the tuned
ones; a compiler killed by a signal (the out-of-memory killer) is reported as that, once;
$LAGDSL_OPTIMIZE sets the optimisation level of both sets.

Each fake compiler is a shell script named by $CC that logs its command line, then behaves as a
compiler would in that case (or hands over to the real one).
"""
from __future__ import annotations

import shutil
import stat

import pytest

from lagdsl.errors import LagError
from lagdsl.run import toolchain

SOURCE = "double lag_answer(void) { return 42.0; }\n"
REAL_COMPILER = shutil.which("cc") or shutil.which("gcc")

# What each fake does after logging its arguments; the OpenMP probe (a program without -shared) is
# answered "no" by all of them, so the log shows only the library builds.
BEHAVIOUR = {
    "killed": 'kill -KILL $$',
    "oom-under-the-driver": "echo 'gcc: fatal error: Killed signal terminated program cc1' >&2; exit 1",
    "refuses-march-native": ('case " $* " in *" -march=native "*)\n'
                             """  echo "cc1: error: bad value 'native' for '-march=' switch" >&2; exit 1;; esac\n"""
                             'exec "$REAL_CC" "$@"'),
    "broken-code": "echo 'model.c:1:1: error: expected expression' >&2; exit 1",
}


@pytest.fixture(autouse=True)
def shipped_flags(monkeypatch):
    """The flags lagdsl ships, whatever LAGDSL_OPTIMIZE the suite runs with."""
    monkeypatch.delenv(toolchain.OPTIMIZE_VARIABLE, raising=False)


@pytest.fixture
def fake_compiler(tmp_path, monkeypatch):
    """Make $CC the fake compiler of `behaviour`; returns the file where it logs each command line."""
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("REAL_CC", REAL_COMPILER)
    toolchain.supports_openmp.cache_clear()

    def install(behaviour: str):
        log, script = tmp_path / "calls.log", tmp_path / "fake-cc"
        script.write_text(f'#!/bin/sh\ncase " $* " in *" -shared "*) ;; *) exit 1;; esac\n'
                          f'echo "$*" >> "{log}"\n{BEHAVIOUR[behaviour]}\n')
        script.chmod(script.stat().st_mode | stat.S_IXUSR)
        monkeypatch.setenv("CC", str(script))
        return log
    yield install
    toolchain.supports_openmp.cache_clear()


def calls(log) -> list[str]:
    return log.read_text().splitlines() if log.exists() else []


@pytest.mark.parametrize("behaviour", ["killed", "oom-under-the-driver"])
def test_a_killed_compiler_is_reported_and_not_run_again(fake_compiler, behaviour):
    log = fake_compiler(behaviour)
    with pytest.raises(LagError, match=r"was killed by .*out-of-memory killer.*--backend numpy") as raised:
        toolchain.shared_library(SOURCE, "answer")
    assert ("signal 9 (SIGKILL)" in str(raised.value)) == (behaviour == "killed")
    assert len(calls(log)) == 1 and "-march=native" in calls(log)[0]


def test_a_compiler_that_refuses_march_native_gets_the_portable_flags(fake_compiler):
    log = fake_compiler("refuses-march-native")
    library = toolchain.shared_library(SOURCE, "answer")
    assert library.exists()
    tuned, portable = calls(log)
    assert "-march=native" in tuned and "-march=native" not in portable and " -O2 " in f" {portable} "


def test_a_real_compiler_that_refuses_a_tuned_flag_gets_the_portable_ones(tmp_path, monkeypatch):
    """The real compiler's own words for a flag it does not know are recognised."""
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(toolchain, "LIBRARY_FLAGS", (*toolchain.LIBRARY_FLAGS, "-fno-such-flag-anywhere"))
    assert toolchain.shared_library(SOURCE, "answer", openmp=False).exists()


def test_an_error_in_the_generated_code_is_not_retried(fake_compiler):
    log = fake_compiler("broken-code")
    with pytest.raises(toolchain.CompilerFailed, match="expected expression"):
        toolchain.shared_library(SOURCE, "answer")
    assert len(calls(log)) == 1


def test_lagdsl_optimize_sets_the_level_of_the_tuned_and_the_portable_flags(fake_compiler, monkeypatch):
    log = fake_compiler("refuses-march-native")
    monkeypatch.setenv(toolchain.OPTIMIZE_VARIABLE, "0")
    assert toolchain.shared_library(SOURCE, "answer").exists()
    tuned, portable = calls(log)
    assert " -O0 " in f" {tuned} " and " -O0 " in f" {portable} " and "-O3" not in tuned and "-O2" not in portable
    assert "-march=native" in tuned


def test_a_library_built_at_another_level_is_another_cache_entry(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "cache"))
    shipped = toolchain.shared_library(SOURCE, "answer", openmp=False)
    monkeypatch.setenv(toolchain.OPTIMIZE_VARIABLE, "1")
    assert toolchain.shared_library(SOURCE, "answer", openmp=False) != shipped


def test_an_unknown_optimisation_level_is_refused_by_name(monkeypatch):
    monkeypatch.setenv(toolchain.OPTIMIZE_VARIABLE, "-O3")
    with pytest.raises(LagError, match=r"LAGDSL_OPTIMIZE='-O3' is not an optimisation level: set it to one of 0, 1"):
        toolchain.library_flags("cc", openmp=False)
