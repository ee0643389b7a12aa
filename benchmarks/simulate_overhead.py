"""What a repeated simulate()'s overhead (its wall time less summary.wall_time, the C call's own
duration) follows: the length of the integration before it, not the size of its output.

In one process, taking turns 20 calls at a time (the same load for all), with the same inputs:
the triple pendulum with its 2001 rows and with 11 (`interval = 2`, nearly the same integration);
the elastic pendulum as it is (0.3-0.7 ms) and 15x as long with the same 1001 rows; and the elastic
pendulum after a C function that touches no memory has spun for as long as the triple pendulum
integrates, the second call after that spin, and after one that writes 8 MB (as much as the
caches hold). Then the machine's own share, without lagdsl: a fixed piece of pure Python (about
as much as a call's overhead) timed right after the previous one, and after that same spin.
For each: the overhead's median and spread (lowest and highest tenth), the median integration,
and what the calls cost in minor page faults and garbage collections (counted around the timed
calls only: causes ruled out when they are 0).

    python benchmarks/simulate_overhead.py            # 400 calls of each, about 20 s
"""
from __future__ import annotations

import argparse
import ctypes
import gc
import resource
import statistics
import subprocess
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import lagdsl

MODELS = Path(__file__).resolve().parents[1] / "models"
SPIN = r"""
#include <string.h>
#include <time.h>
static char caches[8 << 20];
double spin(double seconds) {          /* arithmetic only, for `seconds` */
    struct timespec a, b; double x = 1.0;
    clock_gettime(CLOCK_MONOTONIC, &a);
    do { for (int i = 0; i < 10000; i++) x = x * 1.0000001 + 1e-9; clock_gettime(CLOCK_MONOTONIC, &b); }
    while ((b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec) < seconds);
    return x;
}
void evict(void) { memset(caches, 1, sizeof caches); }
"""


def spinner(work: str) -> ctypes.CDLL:
    """The spin and evict functions above, built in `work`."""
    source, library = Path(work, "spin.c"), Path(work, "spin.so")
    source.write_text(SPIN)
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", str(source), "-o", str(library)], check=True)
    functions = ctypes.CDLL(str(library))
    functions.spin.argtypes, functions.spin.restype = [ctypes.c_double], ctypes.c_double
    return functions


@dataclass(frozen=True)
class Record:
    name: str
    value: float


def plain_python() -> None:
    """Python of the kind a call's overhead runs (dicts, a frozen dataclass, calls), no lagdsl, no C."""
    records = {str(i): Record(str(i), i * 2.0) for i in range(8)}
    [replace(record, value=1.0) for record in records.values()]


def cases(functions: ctypes.CDLL, integration: float, models: dict) -> dict:
    """Each case: (what is timed, what runs before it); what is timed returns a Result, whose
    integration is taken off its time, or None."""
    nothing = lambda: None      # noqa: E731
    triple, elastic = models["triple_pendulum"], models["elastic_pendulum"]

    def spin() -> None:
        functions.spin(integration)

    def spin_and_call() -> None:
        spin()
        elastic.simulate()
    return {"triple pendulum, 2001 rows": (triple.simulate, nothing),
            "triple pendulum, 11 rows": (lambda: triple.simulate(interval=2), nothing),
            "elastic pendulum": (elastic.simulate, nothing),
            "elastic pendulum, 15x as long": (lambda: elastic.simulate(stop=150, interval=0.15), nothing),
            "elastic, after a C spin": (elastic.simulate, spin),
            "elastic, 2nd call after the spin": (elastic.simulate, spin_and_call),
            "elastic, after writing 8 MB": (elastic.simulate, functions.evict),
            "plain Python (no lagdsl)": (plain_python, nothing),
            "plain Python, after the C spin": (plain_python, spin)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=400, help="timed calls of each case")
    calls = parser.parse_args().calls
    models = {name: lagdsl.load(MODELS / f"{name}.lag") for name in ("triple_pendulum", "elastic_pendulum")}
    integration = models["triple_pendulum"].simulate().summary.wall_time
    collections = []
    gc.callbacks.append(lambda phase, info: collections.append(1) if phase == "start" else None)
    with tempfile.TemporaryDirectory() as work:
        chosen = cases(spinner(work), integration, models)
        for timed, _ in chosen.values():
            timed()                                     # planned and prepared: the repeated path
        overheads = {label: [] for label in chosen}
        integrations = {label: [] for label in chosen}
        costs = {label: [0, 0] for label in chosen}     # minor page faults, collections
        for _ in range(calls // 20):
            for label, (timed, before) in chosen.items():
                for _ in range(20):
                    before()
                    faults, collected = resource.getrusage(resource.RUSAGE_SELF).ru_minflt, len(collections)
                    started = time.perf_counter()
                    result = timed()
                    wall = time.perf_counter() - started
                    costs[label][0] += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults
                    costs[label][1] += len(collections) - collected
                    spent = result.summary.wall_time if result is not None else 0.0
                    overheads[label].append(wall - spent)
                    integrations[label].append(spent)
    for label in chosen:
        tenths = statistics.quantiles(overheads[label], n=10)
        faults, collected = costs[label]
        print(f"{label:<34} overhead median {statistics.median(overheads[label]) * 1e6:5.0f} us, tenths "
              f"{tenths[0] * 1e6:5.0f} .. {tenths[-1] * 1e6:5.0f} us; integration "
              f"{statistics.median(integrations[label]) * 1e3:5.2f} ms; {faults / len(overheads[label]):.2f} page faults "
              f"a call, {collected} collections")


if __name__ == "__main__":
    main()
