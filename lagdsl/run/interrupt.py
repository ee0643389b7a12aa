"""Ctrl-C during a run: never lost, and a C run stays interruptible while it holds no GIL.

`interruptible` makes a foreign call in the calling thread when nothing is to be reported while
it runs (the library's Ctrl-C guard sets the run's stop flag, `_Guarded`), else in a worker
thread, so that the main thread stays free for Ctrl-C and progress reports; `CtrlC` installs, during a run, a
SIGINT handler that sets the run's stop flag before Python gets a chance to drop the
KeyboardInterrupt.
"""
from __future__ import annotations

import _signal      # signal's own functions, without the enum conversions of `signal` (a tenth of a short run)
import _thread
import ctypes
import os
import signal
import threading
import time as clock
from collections.abc import Callable

from ..abi import INTERRUPTED
from ..errors import InternalError

POLL_SECONDS = 0.1      # how often the main thread looks at a C run: Ctrl-C and progress
_SIGINT, _SIGTERM = int(signal.SIGINT), int(signal.SIGTERM)     # plain ints: no enum lookups in a call
_default_int_handler = signal.default_int_handler


class RunInterrupt:
    """A library's lag_interrupt (`flag`), which its driver reads after each step, and its Ctrl-C
    guard (`enter(terminate)`, `exit()` giving the signal noted or 0: library.c; both None where
    the library has none); `noted`, where lag_run_guarded puts the signal it noted (through
    `noted_at`, its pointer, made once)."""

    def __init__(self, library: ctypes.CDLL):
        self.flag = ctypes.c_int.in_dll(library, "lag_interrupt")
        self.noted = ctypes.c_int()
        self.noted_at = ctypes.pointer(self.noted)
        self.enter = self.exit = None
        if hasattr(library, "lag_guard_enter"):
            self.enter = ctypes.PYFUNCTYPE(None, ctypes.c_int)(("lag_guard_enter", library))
            self.exit = ctypes.PYFUNCTYPE(ctypes.c_int)(("lag_guard_exit", library))


def interruptible(interrupt: RunInterrupt, call: Callable[..., int],
                  poll: Callable[[], None] | None, arguments: tuple = (),
                  guarded: Callable[..., int] | None = None) -> tuple[int, float]:
    """Make the C call `call(*arguments)` (its status INTERRUPTED where lag_interrupt stopped it)
    in a worker thread, so that the main thread stays free for Ctrl-C and `poll` (called every
    POLL_SECONDS: progress reports). `guarded`, where given, is `call` within the library's guard
    in one foreign call (lag_run_guarded: the guard's terminate flag and a pointer to the signal
    noted come before `arguments`), for a call made in the calling thread (_Guarded).
    Returns its status and its duration, timed in the worker: the main thread notices the end
    only at its next poll, up to POLL_SECONDS later.

    ctypes releases the GIL during the call, and a blocked foreign call would otherwise hold back
    KeyboardInterrupt until the whole run is over. Ctrl-C sets the library's lag_interrupt flag,
    which the driver reads after each step (status LAG_ERR_INTERRUPTED, the rows so far kept);
    further Ctrl-Cs while it winds down change nothing.
    """
    if poll is None:
        done = called_here(interrupt, call, arguments, guarded)
        if done is not None:
            return done
    interrupt.flag.value = 0
    outcome: list[tuple[int, float]] = []
    ended: list[bool] = []          # set before `finished` is released
    finished = _thread.allocate_lock()
    finished.acquire()

    def work() -> None:
        try:
            started = clock.perf_counter()
            status = call(*arguments)
            outcome.append((status, clock.perf_counter() - started))
        finally:
            ended.append(True)
            finished.release()

    worker = _idle_workers.pop() if _idle_workers else _Worker()
    worker.start(work)
    # The wait ends as soon as the run does, so a run of milliseconds does not wait out a poll
    # interval. Ctrl-C is caught wherever the main thread is in the loop, in the wait, the test
    # of `ended` or the poll: Python raises KeyboardInterrupt at whichever bytecode it reaches
    # next (and CtrlC has set the flag even if that bytecode was a finaliser's, which drops the
    # exception); `ended`, not the lock, says when to stop waiting, since the exception may come
    # just after the lock was taken.
    with CtrlC(lambda: setattr(interrupt.flag, "value", 1)):
        while not ended:
            try:
                finished.acquire(timeout=POLL_SECONDS)
                if poll is not None:
                    poll()
            except KeyboardInterrupt:
                interrupt.flag.value = 1
    _idle_workers.append(worker)
    if not outcome:
        raise InternalError("the C run ended without a status")
    return outcome[0]


class _Guarded:
    """A C call made in the calling thread, Ctrl-C still stopping it: no hand-over to a worker,
    which costs a few microseconds idle and hundreds on a loaded machine, where a fit makes
    thousands of short calls.

    While the call runs, the main thread executes no Python, so no Python signal handler can set
    the run's stop flag. The library's own guard (lag_guard_enter and lag_guard_exit, library.c)
    therefore makes SIGINT (and SIGTERM, where terminate_as_interrupt made it an interrupt) set
    lag_interrupt for the duration of the call, the driver stopping after its step with the rows
    so far, and note the press, raising nothing, so that no KeyboardInterrupt can fall between the
    call's end and its status being kept; then it puts Python's handlers back as they were. A
    press that came too late to stop the run is raised as KeyboardInterrupt after it; one that
    came before the guard was in place reaches Python's handler, which raises it before the call.
    The guard's two functions hold the GIL (a thread that took it meanwhile would delay the call
    by up to the switch interval) and cost two system calls in all, four with SIGTERM.
    A run of lag_run that the library can guard itself (`guarded`, lag_run_guarded) is one
    foreign call, the guard's in it: the three foreign calls cost a repeated simulate() several
    microseconds each after a long run has emptied the caches. A press that comes in the
    microsecond before its guard is in place, with the GIL already released, is raised after the
    run instead of before it.

    Used where nothing else needs the signals: another thread (no signal reaches it; the main
    thread's Ctrl-C does not stop it, as with a worker), or the main thread with Python's own
    SIGINT handler and no wakeup descriptor of someone else's (asyncio's, which a press must
    still reach), with a library that has the guard (POSIX); otherwise None (`interruptible`
    hands the call to a worker).
    """

    _active: list[RunInterrupt] = []            # the guard in place now, in the main thread (at most one)

    @classmethod
    def call(cls, interrupt: RunInterrupt, call: Callable[..., int], arguments: tuple,
             guarded: Callable[..., int] | None) -> tuple[int, float] | None:
        if _thread.get_ident() != _main_thread:
            interrupt.flag.value = 0
            started = clock.perf_counter()
            status = call(*arguments)
            return status, clock.perf_counter() - started
        if interrupt.enter is None or _signal.getsignal(_SIGINT) is not _default_int_handler:
            return None
        replaced = _signal.set_wakeup_fd(-1)
        if replaced != -1:                      # someone else's (asyncio's): given back, the call made by a worker
            _signal.set_wakeup_fd(replaced)
            return None
        terminate = _signal.getsignal(_SIGTERM) is _terminated
        cls._active.append(interrupt)
        if guarded is None:
            status, elapsed, noted = cls._enclosed(interrupt, terminate, call, arguments)
        else:
            try:
                started = clock.perf_counter()
                status = guarded(terminate, interrupt.noted_at, *arguments)
                elapsed = clock.perf_counter() - started
            finally:
                cls._active.clear()
            noted = interrupt.noted.value
            if noted == _SIGTERM:
                _terminated_note()
        if noted and status != INTERRUPTED:     # the run ended before its next look at the flag
            raise KeyboardInterrupt
        return status, elapsed

    @classmethod
    def _enclosed(cls, interrupt: RunInterrupt, terminate: bool, call: Callable[..., int],
                  arguments: tuple) -> tuple[int, float, int]:
        """`call` between the guard's two functions: its status, duration and the signal noted."""
        interrupt.flag.value = 0
        try:
            interrupt.enter(terminate)
            started = clock.perf_counter()
            status = call(*arguments)
            elapsed = clock.perf_counter() - started
        finally:
            noted = interrupt.exit()
            cls._active.clear()
            if noted == _SIGTERM:
                _terminated_note()
        return status, elapsed, noted

    @classmethod
    def forked(cls) -> None:
        """In a child forked (by another thread) during a guarded call: Python's handlers back."""
        for interrupt in cls._active:
            interrupt.exit()
        cls._active.clear()


class _Worker:
    """A thread kept for the C calls of `interruptible`, one call at a time: handing a call to a
    waiting thread costs microseconds, starting a thread (threading.Thread.start waits until it
    runs) tens of them, which a fit's thousands of short simulate() calls would pay each time."""

    def __init__(self):
        self._go = _thread.allocate_lock()
        self._go.acquire()
        self._call: Callable[[], None] = lambda: None
        _thread.start_new_thread(self._serve, ())

    def start(self, call: Callable[[], None]) -> None:
        self._call = call
        self._go.release()

    def _serve(self) -> None:
        while True:
            self._go.acquire()
            try:
                self._call()
            except BaseException:       # noqa: BLE001  the caller says the run ended without a status
                pass


called_here = _Guarded.call     # the call made in the calling thread, or None: for a caller with nothing to poll
_idle_workers: list[_Worker] = []       # list.pop and append are atomic: callers in several threads each take one
_main_thread = threading.main_thread().ident        # threading.main_thread().ident: two Python-level calls


def _forked() -> None:
    """In a forked child: none of the parent's threads, nor the call its main thread was making;
    the thread that forked is the child's main thread."""
    global _main_thread
    _idle_workers.clear()
    _Guarded.forked()
    _main_thread = _thread.get_ident()


os.register_at_fork(after_in_child=_forked)


def terminate_as_interrupt() -> None:
    """Make SIGTERM (`kill`, a batch system's time limit) stop a run as Ctrl-C does, keeping the
    rows computed so far: what `lagc` asks for; a Python program using lagdsl keeps SIGTERM's
    default, which ends the process."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminated)


def terminated() -> bool:
    """Whether SIGTERM was received since terminate_as_interrupt()."""
    return _received_sigterm


_received_sigterm = False


def _terminated(signal_number, frame) -> None:
    _terminated_note()
    signal.default_int_handler(signal_number, frame)


def _terminated_note() -> None:
    global _received_sigterm
    _received_sigterm = True


class CtrlC:
    """Ctrl-C during a run, never lost.

    Python's SIGINT handler raises KeyboardInterrupt at the next bytecode the main thread runs,
    and when that bytecode belongs to a finaliser (the __del__ of some object the cyclic
    collector frees just then) Python prints "Exception ignored" and drops it: the press is lost
    and the run goes on. While such contexts are open in the main thread, and if SIGINT had
    Python's default handler when the first was opened, a press first calls every open
    context's `on_press` and sets its `pressed`, which the run's loops test between steps
    (`check`), and then raises as usual. Contexts within one another (the runs of a NumPy sweep)
    share the one handler, which is put back when the last of them closes, in whatever order
    they close (one opened in a generator closes when the generator is collected). SIGTERM,
    where terminate_as_interrupt() made it an interrupt, is handled the same way.
    """

    _open: list[CtrlC] = []                     # the main thread's contexts open now
    _replaced: dict[int, Callable] = {}         # the handlers that _on_signal stands in for

    def __init__(self, on_press: Callable[[], None] = lambda: None):
        self.pressed = False
        self._on_press = on_press

    def __enter__(self) -> CtrlC:
        if threading.current_thread() is threading.main_thread():
            CtrlC._open.append(self)
            for number, default in ((signal.SIGINT, signal.default_int_handler), (signal.SIGTERM, _terminated)):
                if _signal.getsignal(number) is default:
                    CtrlC._replaced[number] = _signal.signal(number, _on_signal)
        return self

    def __exit__(self, *exception) -> None:
        if self in CtrlC._open:
            CtrlC._open.remove(self)
        if not CtrlC._open:
            for number, replaced in CtrlC._replaced.items():
                if _signal.getsignal(number) is _on_signal:
                    _signal.signal(number, replaced)
            CtrlC._replaced.clear()

    def check(self) -> None:
        """Raise KeyboardInterrupt if Ctrl-C was pressed (its own exception may have been dropped)."""
        if self.pressed:
            raise KeyboardInterrupt

    def checked(self, function: Callable) -> Callable:
        """`function`, checking for Ctrl-C before each call: the right-hand side of a Python loop."""
        def checked_function(*arguments):
            self.check()
            return function(*arguments)
        return checked_function


def _on_signal(signal_number, frame) -> None:
    """SIGINT (or SIGTERM as an interrupt) while CtrlC contexts are open: each is pressed, then
    KeyboardInterrupt is raised as Python's own handler would."""
    if signal_number == signal.SIGTERM:
        _terminated_note()
    for context in list(CtrlC._open):
        context.pressed = True
        context._on_press()
    raise KeyboardInterrupt
