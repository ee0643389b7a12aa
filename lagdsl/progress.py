"""Progress on standard error, one mechanism for every command that can take long: a tqdm bar.

A bar appears only after DELAY seconds (a short command prints nothing) and only on a terminal
(logs and pipes stay clean); it erases itself when done, before the summary is printed.
"""
from __future__ import annotations

import contextlib
import sys
import threading

DELAY = 2.0       # seconds before a bar is shown
NOTICE = 60.0     # seconds after which a stage without a bar says what it is doing


def bar(total: float, unit: str, description: str = "lagc", stream=None, **options):
    """A tqdm bar on `stream` (standard error)."""
    from tqdm import tqdm
    return tqdm(total=total, unit=unit, desc=description, file=stream or sys.stderr, dynamic_ncols=True,
                delay=DELAY, disable=None, leave=False, **options)


class TimeProgress:
    """A run's progress in its own time, as progress(t reached, start, stop), which the runners
    call every so often (the C runner every poll, the NumPy one after every step)."""

    FORMAT = "{desc}: {percentage:3.0f}%|{bar}| t - t0 = {n:.6g} of {total:.6g} [{elapsed}<{remaining}]"

    def __init__(self, stream=None, **options):
        self.stream, self.options = stream, options
        self.bar = None

    def __call__(self, t: float, start: float, stop: float) -> None:
        if self.bar is None:
            self.bar = bar(stop - start, "s", stream=self.stream, bar_format=self.FORMAT, **self.options)
        self.bar.update(min(t, stop) - start - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


@contextlib.contextmanager
def slow_stage(doing: str, stream=None):
    """Within the block, a note on standard error once it has taken NOTICE seconds: `lagc: still
    DOING after 60 s`. Stages without a measure of progress (deriving the equations of a large
    model, compiling its code) never run for minutes without saying why."""
    timer = threading.Timer(NOTICE, lambda: print(f"lagc: still {doing} after {NOTICE:.0f} s",
                                                    file=stream or sys.stderr, flush=True))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
