"""Helpers shared by the benchmark scripts: one core, timing, time limits, tables, the machine.

Import this module before anything that imports NumPy (lagdsl does): it fixes the BLAS and
OpenMP thread counts to one, so that "one core" holds for NumPy's linear algebra too.
"""
from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import contextlib  # noqa: E402
import gc  # noqa: E402
import platform  # noqa: E402
import shutil  # noqa: E402
import signal  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

BENCHMARKS = Path(__file__).resolve().parent
REPOSITORY = BENCHMARKS.parent
MODELS = REPOSITORY / "models"


# ---- one core ------------------------------------------------------------------------------
def pin_to_one_core() -> int:
    """Run this process (and the compilers it starts) on one CPU; returns that CPU's number."""
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return core


# ---- timing --------------------------------------------------------------------------------
def fresh_start() -> None:
    """Empty SymPy's global cache and collect garbage, so no measurement profits from the last."""
    from sympy.core.cache import clear_cache
    clear_cache()
    gc.collect()


def cpu_seconds() -> float:
    """CPU time of this process. The benchmarks time CPU, not wall-clock, time: the machine is
    shared (2 cores, other work running), and time spent descheduled is not the code's cost.
    The process is single-threaded on one core, so on an idle machine the two agree."""
    return time.process_time()


def timed(function, *args):
    """(CPU seconds, result) of one call, started from an empty SymPy cache."""
    fresh_start()
    started = cpu_seconds()
    result = function(*args)
    return cpu_seconds() - started, result


def best_of(repeat: int, function, *args):
    """(best CPU seconds, result of the best run) over `repeat` calls."""
    best = None
    for _ in range(max(1, repeat)):
        seconds, result = timed(function, *args)
        if best is None or seconds < best[0]:
            best = (seconds, result)
    return best


class TimeLimitExceeded(BaseException):
    """Raised from SIGALRM when a measurement runs over its limit.

    A BaseException, like KeyboardInterrupt, so that an `except Exception` inside SymPy cannot
    swallow it and let the measurement run on.
    """


@contextlib.contextmanager
def time_limit(seconds: float):
    """Interrupt the body with TimeLimitExceeded after `seconds` (pure-Python work only)."""
    def interrupt(signum, frame):
        raise TimeLimitExceeded()

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


# ---- output --------------------------------------------------------------------------------
def seconds(value) -> str:
    """A duration for a table: 3 significant digits, or the reason it is missing."""
    if isinstance(value, str):
        return value
    if value is None:
        return "n/a"
    return f"{value:.3g} s" if value >= 1 else f"{value * 1e3:.3g} ms"


def ratio(numerator, denominator) -> str:
    if not isinstance(numerator, (int, float)) or not isinstance(denominator, (int, float)) or not denominator:
        return "n/a"
    value = numerator / denominator
    return f"{value:.3g}x"


def markdown_table(headers, rows) -> str:
    """A Markdown pipe table, columns padded, every column but the first right-aligned."""
    cells = [[str(h) for h in headers]] + [[str(c) for c in row] for row in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(headers))]

    def line(row):
        padded = [row[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(row[1:], widths[1:])]
        return "| " + " | ".join(padded) + " |"

    rule = "|" + "|".join(["-" * (widths[0] + 2)] + ["-" * (w + 1) + ":" for w in widths[1:]]) + "|"
    return "\n".join([line(cells[0]), rule] + [line(row) for row in cells[1:]])


def machine_description() -> str:
    """CPU, cores, Python and library versions, C compiler: printed above every result table."""
    cpu = platform.processor() or "unknown CPU"
    try:
        for text in Path("/proc/cpuinfo").read_text().splitlines():
            if text.startswith("model name"):
                cpu = text.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numpy
    import scipy
    import sympy
    compiler = "no C compiler"
    if shutil.which("cc"):
        compiler = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return (f"{cpu}, {os.cpu_count()} cores (measured on one); Python {platform.python_version()}, "
            f"SymPy {sympy.__version__}, NumPy {numpy.__version__}, SciPy {scipy.__version__}; {compiler}")


# ---- peers -----------------------------------------------------------------------------------
def hand_rhs(t, y, m1, m2, l1, l2, g):
    """The textbook equations of the plane double pendulum (angles from the downward vertical),
    solved for the accelerations by hand, as a scipy user would write them."""
    import math

    import numpy as np
    th1, th2, w1, w2 = y
    d = th1 - th2
    c, s = math.cos(d), math.sin(d)
    a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
    b1 = -m2 * l1 * l2 * s * w2 * w2 - (m1 + m2) * g * l1 * math.sin(th1)
    b2 = m2 * l1 * l2 * s * w1 * w1 - m2 * g * l2 * math.sin(th2)
    det = a11 * a22 - a12 * a12
    return np.array([w1, w2, (b1 * a22 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det])


def cyrk_double_pendulum():
    """(numba, CyRK's nbsolve_ivp, the double pendulum's right-hand side as a numba function), or
    None without CyRK. The right-hand side is the textbook one, written as a user would: Cramer's
    rule on M q'' = F for y = (theta1, theta2, theta1', theta2') and args (m1, m2, l1, l2, g)."""
    try:
        import numba
        import numpy as np
        from CyRK import nbsolve_ivp
    except ImportError:
        return None

    @numba.njit(cache=False)
    def rhs(t, y, m1, m2, l1, l2, g):
        d = y[0] - y[1]
        c, s = np.cos(d), np.sin(d)
        a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
        b1 = -m2 * l1 * l2 * s * y[3] * y[3] - (m1 + m2) * g * l1 * np.sin(y[0])
        b2 = m2 * l1 * l2 * s * y[2] * y[2] - m2 * g * l2 * np.sin(y[1])
        det = a11 * a22 - a12 * a12
        dy = np.empty(4)
        dy[0], dy[1] = y[2], y[3]
        dy[2] = (b1 * a22 - a12 * b2) / det
        dy[3] = (a11 * b2 - a12 * b1) / det
        return dy

    return numba, nbsolve_ivp, rhs
