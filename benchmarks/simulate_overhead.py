"""What a repeated simulate()'s overhead (its wall time less summary.wall_time, the C call's own
duration) follows: the length of the integration before it, not the size of its output.

In one process, taking turns 20 calls at a time (the same load for all), with the same inputs:
the triple pendulum with its 2001 rows and with 11 (`interval = 2`, nearly the same integration);
the elastic pendulum as it is (0.7 ms) and 15x as long with the same 1001 rows; and the elastic
pendulum after a C function that touches no memory has spun for as long as the triple pendulum
integrates, the second call after that spin, and after one that writes 8 MB (as much as the
caches hold). For each: the median and lowest tenth of the overhead, and the median integration.

    python benchmarks/simulate_overhead.py            # 400 calls of each, about 20 s
"""
from __future__ import annotations

import argparse
import ctypes
import statistics
import subprocess
import tempfile
import time
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


def cases(functions: ctypes.CDLL, integration: float, elastic) -> dict:
    """Each case: (model, simulate()'s arguments, what runs before the timed call); `elastic` is
    the elastic pendulum's Model."""
    nothing = lambda: None      # noqa: E731

    def spin_and_call() -> None:
        functions.spin(integration)
        elastic.simulate()
    return {"triple pendulum, 2001 rows": ("triple_pendulum", {}, nothing),
            "triple pendulum, 11 rows": ("triple_pendulum", {"interval": 2}, nothing),
            "elastic pendulum": ("elastic_pendulum", {}, nothing),
            "elastic pendulum, 15x as long": ("elastic_pendulum", {"stop": 150, "interval": 0.15}, nothing),
            "elastic, after a C spin": ("elastic_pendulum", {}, lambda: functions.spin(integration)),
            "elastic, 2nd call after the spin": ("elastic_pendulum", {}, spin_and_call),
            "elastic, after writing 8 MB": ("elastic_pendulum", {}, functions.evict)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=400, help="timed simulate() calls of each case")
    calls = parser.parse_args().calls
    models = {name: lagdsl.load(MODELS / f"{name}.lag") for name in ("triple_pendulum", "elastic_pendulum")}
    integration = models["triple_pendulum"].simulate().summary.wall_time
    with tempfile.TemporaryDirectory() as work:
        chosen = cases(spinner(work), integration, models["elastic_pendulum"])
        for name, arguments, _ in chosen.values():
            models[name].simulate(**arguments)          # planned and prepared: the repeated path
        overheads = {label: [] for label in chosen}
        integrations = {label: [] for label in chosen}
        for _ in range(calls // 20):
            for label, (name, arguments, before) in chosen.items():
                for _ in range(20):
                    before()
                    started = time.perf_counter()
                    result = models[name].simulate(**arguments)
                    overheads[label].append(time.perf_counter() - started - result.summary.wall_time)
                    integrations[label].append(result.summary.wall_time)
    for label in chosen:
        print(f"{label:<34} overhead median {statistics.median(overheads[label]) * 1e6:6.0f} us, lowest tenth "
              f"{statistics.quantiles(overheads[label], n=10)[0] * 1e6:6.0f} us; integration "
              f"{statistics.median(integrations[label]) * 1e3:6.2f} ms")


if __name__ == "__main__":
    main()
