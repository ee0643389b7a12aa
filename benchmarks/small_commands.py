"""How long the small commands take, warm, against the goals of issue 36 (and issue 30's
`lagc modes` on the 200-mass chain, warm and cold).

Each command first runs once to fill the build cache (its own, a temporary directory, or
$LAGDSL_CACHE), then `--repeat` times; the median counts. The cold `lagc modes` runs each time
with a new, empty cache instead (as after `lagc cache clear`). The commands' processes may write
Python's bytecode caches (PYTHONDONTWRITEBYTECODE is left out of their environment), as an
installed lagdsl has them: compiling lagdsl's modules anew in every process is not a cost users pay. A command's CPU time is that of its
process (resource.getrusage of the children), which a loaded machine inflates less than the
wall time; both are printed. The repeated simulate() runs in a process of its own, with nothing
run in it before (see simulate_overhead_apart): its overhead is the
call's wall time less the integration's (summary.wall_time, timed around the C call), and its
CPU time per call over a run of calls (the integration's included). The goal holds for
integrations of the length the issue measured (HELD); a longer one is printed with what the
machine adds to any Python after it (LONG_RUN).

    python benchmarks/small_commands.py              # about a minute warm, more on a fresh cache
    python benchmarks/small_commands.py --repeat 9
    python benchmarks/small_commands.py --against /tmp/main   # simulate() only, main's lagdsl in turns with this one,
                                                              # the same inputs and new ones (CASES)
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
CHECKED = ("double_pendulum", "kepler", "elastic_pendulum", "spring_chain")
SWEEP = ("sweep", MODELS / "double_pendulum.lag", "--vary", "theta1.start=-1:1:20", "--stop", "10")
# The repeated simulate()s held to the goal, as the issue measured them: integrations of 0.14-0.2
# ms (the elastic pendulum's scene; the triple pendulum's first second), by label: the model and
# simulate()'s arguments. The triple pendulum's whole chaos scene (about 5 ms) is printed beside
# them with the machine's own share: after a C call that long, any Python runs slower
# (simulate_overhead.py), measured on a piece of plain Python after a C spin as long (machine_share).
HELD = {"elastic_pendulum": ("elastic_pendulum", {}), "triple_pendulum, stop = 1": ("triple_pendulum", {"stop": 1})}
LONG_RUN = ("triple_pendulum", {})
# The repeated simulate()s compared with --against, by model: (a) the same inputs, (b) a new value
# of a parameter nothing else is computed from, (c) a new value of one a start value is computed
# from (the elastic pendulum's s.start = m g cos(phi0)/k; the triple pendulum has none), (d) a new
# start value; each a function of the call's number giving simulate()'s arguments.
CASES = {
    "elastic_pendulum": {"a": lambda i: {}, "b": lambda i: {"l": 1 + 1e-6 * i}, "c": lambda i: {"k": 100 + 1e-3 * i},
                         "d": lambda i: {"set": {"phi.start": 1 + 1e-6 * i}}},
    "triple_pendulum": {"a": lambda i: {}, "b": lambda i: {"g": 9.81 + 1e-6 * i},
                        "d": lambda i: {"set": {"theta1.start": 2 + 1e-6 * i}}},
}


def command(*arguments, repeat: int) -> tuple[float, float]:
    """(median wall s, median CPU s) of `lagc arguments`, after one run to warm."""
    return timed([sys.executable, "-m", "lagdsl", *map(str, arguments)], repeat)


def cold_command(work: str, *arguments, repeat: int) -> tuple[float, float]:
    """(median wall s, median CPU s) of `lagc arguments`, each run with a new, empty build cache
    (in `work`)."""
    def fresh_cache() -> dict[str, str]:
        return {"LAGDSL_CACHE": tempfile.mkdtemp(prefix="cold-", dir=work)}
    return timed([sys.executable, "-m", "lagdsl", *map(str, arguments)], repeat, fresh_cache)


def timed(argv: list[str], repeat: int, environment=dict) -> tuple[float, float]:
    """(median wall s, median CPU s) of the process `argv`, after one run to warm; `environment()`
    gives variables to set for each run."""
    walls, cpus = [], []
    inherited = {name: value for name, value in os.environ.items() if name != "PYTHONDONTWRITEBYTECODE"}
    for attempt in range(repeat + 1):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True, env={**inherited, **environment()})
        wall = time.perf_counter() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            sys.exit(f"{' '.join(argv)} failed:\n{done.stderr}")
        if attempt:
            walls.append(wall)
            cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def report(what: str, value: float, goal: float, unit: str = "s", note: str = "") -> None:
    verdict = "ok" if value < goal else "OVER"
    print(f"{what:<52} {value:9.3g} {unit:<3} goal < {goal:g} {unit:<3} {verdict:<4} {note}")


def bench_overhead() -> tuple[float, float]:
    """(wall s, integration s) of model.bench() on the double pendulum in this process, warm: the
    model loaded and every integrator's ladder run, each run's integration (summary.wall_time)
    summed; as `lagc bench --stop 10` but for the imports."""
    import lagdsl
    from lagdsl import api
    spent = []
    simulate_plan = api.Model.simulate_plan

    def timed(self, *arguments, **options):
        result = simulate_plan(self, *arguments, **options)
        spent.append(result.summary.wall_time)
        return result

    api.Model.simulate_plan = timed
    try:
        lagdsl.load(MODELS / "double_pendulum.lag").bench(stop=10)       # fills the cache
        spent.clear()
        started = time.perf_counter()
        lagdsl.load(MODELS / "double_pendulum.lag").bench(stop=10)
        return time.perf_counter() - started, sum(spent)
    finally:
        api.Model.simulate_plan = simulate_plan


def simulate_overhead(name: str, calls: int, arguments: dict) -> tuple[float, float, float, float, float]:
    """(median overhead s, its lowest tenth, its highest tenth, median integration s, CPU s per
    call) of a repeated simulate(**arguments): the lowest tenth is what a call costs when the
    machine's load does not take its core away nor empty its caches during the integration before
    it (see simulate_overhead.py), the highest what it costs when it does."""
    import lagdsl
    model = lagdsl.load(MODELS / f"{name}.lag")
    model.simulate(**arguments)
    overheads, integrations = [], []
    cpu = time.process_time()
    for _ in range(calls):
        started = time.perf_counter()
        result = model.simulate(**arguments)
        overheads.append(time.perf_counter() - started - result.summary.wall_time)
        integrations.append(result.summary.wall_time)
    cpu = (time.process_time() - cpu) / calls
    tenths = statistics.quantiles(overheads, n=10)
    return statistics.median(overheads), tenths[0], tenths[-1], statistics.median(integrations), cpu


def simulate_overhead_apart(name: str, calls: int, arguments: dict) -> tuple[float, float, float, float, float]:
    """simulate_overhead(name, calls, arguments) in a process of its own, as simulate_overhead.py measures
    it. Made in this one after bench_overhead(), the same calls (the same 45 Python-level calls
    each, counted with sys.setprofile; no collection by gc in most) took 56 us median on the
    elastic pendulum against 25 us in a new process (load average 0.65), and 66 against
    simulate_overhead.py's 22 on a quiet machine: the state bench() leaves, not the code."""
    done = subprocess.run([sys.executable, __file__, "--simulate-worker", name, str(calls), json.dumps(arguments)],
                          capture_output=True, text=True, check=True)
    return tuple(json.loads(done.stdout))


def machine_share(work: str, integration: float, calls: int) -> tuple[float, float]:
    """(median s of plain Python warm, median s of the same after a C spin of `integration` s):
    what the machine adds to any Python that follows a C call that long (simulate_overhead.py's
    spin and piece of plain Python, in a process of its own)."""
    import simulate_overhead
    spinner = simulate_overhead.spinner(work)
    warm, after = [], []
    for _ in range(calls):
        for before, times in ((lambda: None, warm), (lambda: spinner.spin(integration), after)):
            before()
            started = time.perf_counter()
            simulate_overhead.plain_python()
            times.append(time.perf_counter() - started)
    return statistics.median(warm), statistics.median(after)


def overhead_worker(name: str, case: str) -> None:
    """Serve `--against`: load `name` (warm), then for each line "N" on stdin make N simulate()
    calls with the arguments of CASES[name][case] and print their overheads (s) as one line of JSON."""
    import lagdsl
    model, arguments = lagdsl.load(MODELS / f"{name}.lag"), CASES[name][case]
    model.simulate(**arguments(0))
    print("ready", flush=True)
    calls = 0
    for line in sys.stdin:
        overheads = []
        for _ in range(int(line)):
            calls += 1
            given = arguments(calls)
            started = time.perf_counter()
            result = model.simulate(**given)
            overheads.append(time.perf_counter() - started - result.summary.wall_time)
        print(json.dumps(overheads), flush=True)


def compared_overheads(name: str, case: str, calls: int, trees: dict[str, str],
                       rounds: int = 10) -> dict[str, list[float]]:
    """The overheads of `calls` repeated simulate() of `name`, CASES[name][case], with each of
    `trees` (a label and the directory its lagdsl is imported from), a process each, taking turns
    in `rounds` rounds: the same load for all."""
    workers = {}
    for label, tree in trees.items():
        workers[label] = subprocess.Popen([sys.executable, __file__, "--overhead-worker", name, case], text=True,
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                          env={**os.environ, "PYTHONPATH": tree})
        if workers[label].stdout.readline().strip() != "ready":
            sys.exit(f"the {label} worker ({tree}) did not start")
    overheads: dict[str, list[float]] = {label: [] for label in trees}
    for _ in range(rounds):
        for label, worker in workers.items():
            worker.stdin.write(f"{calls // rounds}\n")
            worker.stdin.flush()
            overheads[label] += json.loads(worker.stdout.readline())
    for worker in workers.values():
        worker.stdin.close()
        worker.wait()
    return overheads


def compare(against: str, calls: int) -> None:
    """Print the repeated simulate()'s overhead with the lagdsl of `against` and with this tree's."""
    trees = {"before": str(Path(against).resolve()), "after": str(ROOT)}
    print(f"repeated simulate(), {calls} calls each, taking turns; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}; before {trees['before']}, after {trees['after']}")
    for name, cases in CASES.items():
        for case in cases:
            for label, overheads in compared_overheads(name, case, calls, trees).items():
                tenths = statistics.quantiles(overheads, n=10)
                print(f"{name:<18} ({case}) {label:<6} overhead median {statistics.median(overheads) * 1e6:6.0f} us, "
                      f"tenths {tenths[0] * 1e6:5.0f} .. {tenths[-1] * 1e6:5.0f} us", flush=True)
    print(f"load average at the end {', '.join(f'{x:.2f}' for x in os.getloadavg())}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="warm runs of each command (median counts)")
    parser.add_argument("--calls", type=int, default=2000, help="simulate() calls")
    parser.add_argument("--against", metavar="TREE", help="only the repeated simulate(): its overhead with the "
                        "lagdsl in TREE (a checkout of main) and with this tree's, taking turns")
    parser.add_argument("--overhead-worker", nargs=2, metavar=("MODEL", "CASE"), help=argparse.SUPPRESS)
    parser.add_argument("--simulate-worker", nargs=3, metavar=("MODEL", "CALLS", "ARGUMENTS"), help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.overhead_worker:
        return overhead_worker(*arguments.overhead_worker)
    if arguments.simulate_worker:
        name, calls, given = arguments.simulate_worker
        return print(json.dumps(simulate_overhead(name, int(calls), json.loads(given))))
    if arguments.against:
        return compare(arguments.against, arguments.calls)
    with tempfile.TemporaryDirectory(prefix="lagdsl-small-") as work:
        os.environ.setdefault("LAGDSL_CACHE", str(Path(work) / "cache"))
        repeat = arguments.repeat
        print(f"warm, median of {repeat} runs; cache {os.environ['LAGDSL_CACHE']}; load average "
              f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
        for name in CHECKED:
            wall, cpu = command("check", MODELS / f"{name}.lag", repeat=repeat)
            report(f"lagc check {name}.lag: CPU", cpu, 0.5, note=f"({wall:.3g} s wall)")
        wall, cpu = command("modes", MODELS / "spring_chain.lag", repeat=repeat)
        report("lagc modes spring_chain.lag (200 masses): wall", wall, 2.0, note=f"({cpu:.3g} s CPU)")
        wall, cpu = cold_command(work, "modes", MODELS / "spring_chain.lag", repeat=repeat)
        report("lagc modes spring_chain.lag, empty cache: wall", wall, 2.0, note=f"({cpu:.3g} s CPU)")
        wall, cpu = command(*SWEEP, "-o", Path(work) / "sweep.csv", repeat=repeat)
        report("lagc sweep, 20 members: wall", wall, 1.0, note=f"({cpu:.3g} s CPU)")
        wall, integrations = bench_overhead()
        report("model.bench() double_pendulum: overhead / integrations", (wall - integrations) / integrations, 2.0,
               "x", f"({wall:.3g} s wall, integrations {integrations:.3g} s)")
        wall, cpu = timed([sys.executable, "-c", f"import lagdsl; lagdsl.load({str(MODELS / 'double_pendulum.lag')!r})"],
                          repeat)
        report("lagdsl.load(double_pendulum.lag) in a new process: wall", wall, 1.0, note=f"({cpu:.3g} s CPU)")
        wall, cpu = timed([sys.executable, "-c", f"import lagdsl; lagdsl.load({str(MODELS / 'double_pendulum.lag')!r})"
                           ".simulate()"], repeat)
        report("the same and its first simulate(): wall", wall, 1.0, note=f"({cpu:.3g} s CPU)")
        for label, (name, given) in HELD.items():
            overhead, lowest, highest, integration, per_call = simulate_overhead_apart(name, arguments.calls, given)
            report(f"repeated simulate() {label}: overhead", overhead * 1e6, 50, "us",
                   f"(tenths {lowest * 1e6:.0f} .. {highest * 1e6:.0f} us; integration {integration * 1e6:.0f} us, "
                   f"CPU {per_call * 1e6:.0f} us a call)")
        overhead, lowest, highest, integration, _ = simulate_overhead_apart(LONG_RUN[0], arguments.calls, LONG_RUN[1])
        warm, after = machine_share(work, integration, arguments.calls)
        print(f"repeated simulate() {LONG_RUN[0]}, whole scene: overhead {overhead * 1e6:.0f} us (tenths "
              f"{lowest * 1e6:.0f} .. {highest * 1e6:.0f} us) after an integration of {integration * 1e3:.2f} ms; "
              f"the machine's share: plain Python of {warm * 1e6:.0f} us takes {after * 1e6:.0f} us after a C call "
              f"that long")


if __name__ == "__main__":
    main()
