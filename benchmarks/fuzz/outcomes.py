"""The commands a fuzz mutant goes through, and how each outcome is judged.

Shared by the campaign (`campaign.py`) and its CI slice (`tests/test_fuzz_slice.py`). Each
command runs in a child process forked from the caller (so that lagdsl, SymPy and SciPy are
imported once), in its own process group, with a memory limit and a limit on CPU time: the
machine may be shared, so wall-clock time would count other people's work; a child that waits
without computing is stopped after `WALL_FACTOR` times the limit in wall-clock time (generous: on a
busy machine a command gets a small share of a core). An in-process alarm
would not do: SymPy can spend minutes inside one C call (a power of a huge exact number).

Two times judge a command. Running over the hard limit is a hang: the run contract is broken.
Finishing between the soft limit and the hard one is "slow": an answer, but one worth a look. The
gap is there because a run is bounded by its step limit, not by a time: 10^5 steps by default, and
a SciPy step of a small model's NumPy right-hand side costs up to about 1 ms, so an honest
`run numpy` can take a minute and a half of CPU.
Linux only (fork, pidfd).
"""
from __future__ import annotations

import contextlib
import os
import re
import resource
import select
import signal
import sys
import traceback
from pathlib import Path

from lagdsl.cli import main

STOP = "0.1"      # short runs: the point is what the commands do with the mutant, not the physics
COMMANDS = {
    "check": ["check", "{model}"],
    "eom": ["eom", "{model}"],
    "run c": ["run", "{model}", "--stop", STOP, "--backend", "c"],
    "run numpy": ["run", "{model}", "--stop", STOP, "--backend", "numpy"],
    "emit c": ["{model}", "--emit", "c"],
    "emit numpy": ["{model}", "--emit", "numpy"],
}
CATEGORIES = ("success", "located error", "simulation failure", "unlocated error", "slow", "traceback", "signal",
              "hang")
OFFENDING = ("traceback", "signal", "hang")     # lagdsl's bugs; the other outcomes are answers
WALL_FACTOR = 15
MEMORY_LIMIT = 6 * 2**30        # bytes of address space per command: a runaway mutant must not take the machine

LOCATED = re.compile(r"^(?:.+?:\d+:\d+: error: |lagc: error: )", re.M)
EXCEPTION_LINE = re.compile(r"^(\w+(?:\.\w+)*(?:Error|Exception|Interrupt|Exit)\b.*)$", re.M)
FRAME = re.compile(r'^  File "(.*?)", line (\d+), in (\S+)$', re.M)


def arguments(command: str, model: str) -> list[str]:
    return [word.format(model=model) for word in COMMANDS[command]]


def run_isolated(argv: list[str], timeout: float, work: Path) -> tuple[int | None, str, float]:
    """(exit code, stderr, CPU seconds) of `lagc argv` in a child process; the code is None if it ran
    over `timeout` seconds of CPU time (or `WALL_FACTOR` times that in wall-clock time: the child's
    whole process group is then killed), and -N if signal N ended it. The CPU time includes the
    compilers the command started."""
    stdout, stderr = work / "stdout", work / "stderr"
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        _child(argv, stdout, stderr, timeout)
    with contextlib.suppress(OSError):      # the child does it too; whichever runs first
        os.setpgid(pid, pid)
    finished = os.pidfd_open(pid)
    try:
        waited = select.select([finished], [], [], WALL_FACTOR * timeout)[0]
        if not waited:
            os.killpg(pid, signal.SIGKILL)
        _, status, usage = os.wait4(pid, 0)
        exit_code = os.waitstatus_to_exitcode(status) if waited else None
        exit_code = None if exit_code == -signal.SIGXCPU else exit_code
    finally:
        os.close(finished)
    return exit_code, stderr.read_text(encoding="utf-8", errors="replace"), usage.ru_utime + usage.ru_stime


def _child(argv: list[str], stdout: Path, stderr: Path, timeout: float) -> None:
    """In the forked child: redirect the output, set the limits, run the command, never return."""
    code = 1
    try:
        os.setpgid(0, 0)
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
        cpu_seconds = int(timeout) + 1          # a forked child starts with no CPU time used
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds + 5))     # SIGXCPU, then SIGKILL
        for descriptor, path in ((1, stdout), (2, stderr)):
            opened = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(opened, descriptor)
            os.close(opened)
        # Python-level streams too: under pytest they are capture objects, not descriptors 1 and 2.
        sys.stdout = open(1, "w", encoding="utf-8", closefd=False)
        sys.stderr = open(2, "w", encoding="utf-8", closefd=False)
        code = invoke(argv)
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def invoke(argv: list[str]) -> int:
    """`lagc argv` in this process, with the exit code the console script would give.

    An exception escaping `main` prints its traceback and exits 1, as Python does for the
    `lagc` script; the traceback is what the judge looks for.
    """
    try:
        return main(argv)
    except SystemExit as exit_:
        return exit_.code if isinstance(exit_.code, int) else int(exit_.code is not None)
    except Exception:
        traceback.print_exc()
        return 1


def classify(exit_code: int | None, stderr: str, cpu_seconds: float = 0.0, slow_after: float = float("inf")) -> str:
    """One of CATEGORIES. `exit_code` is None after a time-out, negative after a signal; an answer
    that took more than `slow_after` CPU seconds is "slow"."""
    if exit_code is None:
        return "hang"
    if exit_code < 0:
        return "signal"
    if "Traceback" in stderr or "internal error" in stderr or exit_code not in (0, 1):
        return "traceback"
    if cpu_seconds > slow_after:
        return "slow"
    if exit_code == 0:
        return "success"
    if LOCATED.search(stderr):
        return "located error"
    if "simulation failed at t = " in stderr:
        return "simulation failure"
    return "unlocated error"


def signature(category: str, command: str, exit_code: int | None, stderr: str) -> str:
    """A short name for an offending outcome, the same for the same bug: the innermost lagdsl
    frame and the exception, the signal, or the command that hung."""
    if category == "hang":
        return f"hang in '{command}'"
    if category == "signal":
        return f"signal {-exit_code} in '{command}'"
    frames = [f"{path.rsplit('/lagdsl/', 1)[-1]}:{line} {function}" for path, line, function in FRAME.findall(stderr)
              if "/lagdsl/" in path]
    exceptions = EXCEPTION_LINE.findall(stderr)
    exception = exceptions[-1].split(":")[0] if exceptions else f"exit code {exit_code}"
    return f"{exception} at {frames[-1] if frames else '?'}"
