"""Progress on standard error, one mechanism for every command that can take long: a tqdm bar.

A bar appears only after DELAY seconds (a short command prints nothing) and only on a terminal
(logs and pipes stay clean); it erases itself when done, before the summary is printed.
"""
from __future__ import annotations

import sys

DELAY = 2.0       # seconds before a bar is shown


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
