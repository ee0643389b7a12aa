"""How much memory a result may take, checked before a run rather than found by its failure.

A run's rows are held in memory (the C backend's buffer, the NumPy backend's states and
outputs), and a sweep's are (B, T, C) values: a 200-coordinate model at 10^7 rows, or 10^7
members, would ask for tens of GiB and die in the allocator after all the work. So the size is
forecast from the plan, rows x columns x members, and compared with what this process can use:
half of the memory available to it (the address-space limit of `ulimit -v` left over, or the
machine's available memory, whichever is less).
"""
from __future__ import annotations

import os
import resource

from ..errors import LagError

DOUBLE = 8
SHARE = 0.5                    # of the memory available, what one result may take
NUMPY_ROW_OVERHEAD = 112       # bytes a NumPy backend state array costs beside its numbers
SMALL_RESULT = 64 * 2 ** 20    # bytes: a result this small is not checked


def available_bytes() -> int:
    """What this process can still allocate: the address-space limit's room, or the machine's
    available memory (/proc/meminfo's MemAvailable, else the physical memory), whichever is less."""
    machine = _meminfo_available() or os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    limit, _ = resource.getrlimit(resource.RLIMIT_AS)
    if limit == resource.RLIM_INFINITY:
        return machine
    return max(0, min(machine, limit - _address_space_used()))


def budget() -> int:
    """The bytes one result may take."""
    return int(SHARE * available_bytes())


def check_fits(size: int, what: str, remedy: str) -> None:
    """Refuse, before running, a result of `size` bytes that is over budget()."""
    allowed = budget()
    if size > allowed:
        raise LagError(f"{what} would take {_bytes(size)}, more than the {_bytes(allowed)} this process can use "
                       f"for it; {remedy}")


def run_bytes(rows: int, columns: int, coordinates: int, language: str) -> int:
    """The memory of one run's result: the rows (t and the columns) twice (the buffer and the
    Result), and on the NumPy backend its states (one array of 2n numbers a row) as well."""
    size = 2 * rows * (columns + 1) * DOUBLE
    if language == "numpy":
        size += rows * (2 * coordinates * DOUBLE + NUMPY_ROW_OVERHEAD) + 2 * rows * columns * DOUBLE
    return size


def sweep_bytes(members: int, rows: int, columns: int) -> int:
    """The memory of a sweep's values (members x rows x columns) and their tidy table's copy."""
    return 2 * members * rows * columns * DOUBLE


def _bytes(size: int) -> str:
    for unit, scale in (("GiB", 2 ** 30), ("MiB", 2 ** 20), ("KiB", 2 ** 10)):
        if size >= scale:
            return f"{size / scale:.3g} {unit}"
    return f"{size} bytes"


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _address_space_used() -> int:
    """The address space this process has mapped (Linux /proc/self/statm), 0 where unknown."""
    try:
        with open("/proc/self/statm", encoding="ascii") as statm:
            return int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0
