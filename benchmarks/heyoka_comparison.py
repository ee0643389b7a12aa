"""lagdsl's taylor, dop853 and rkn8 against heyoka and CyRK at matched accuracy (issue 34).

Four problems, each integrated by both tools in this one process, pinned to one core:

- the chaotic double pendulum, t = 0..20 every 0.5 (models/double_pendulum.lag, scene chaos);
- the Pleiades, t = 0..3 every 0.01 (models/pleiades.lag, scene stars; the IVP test set's plei);
- the outer solar system over 10^6 days, every 500 days (models/outer_solar_system.lag);
- Kepler's problem at eccentricity 0.6 over 1000 orbits, every tenth of an orbit (polar).

lagdsl's methods: taylor (the default norm, component), taylor-state (taylor(norm = state): one
tolerance for the whole state, Jorba and Zou's and heyoka's control), dop853, rkn8.
Every method runs a ladder of tolerances (rtol = atol = tol for lagdsl, heyoka's tol); the
error of a run is the largest absolute difference from lagdsl's extended-precision reference
over the output rows and the position columns (the angles, the coordinates). Times are CPU
seconds of the integration alone (the machine is shared: CPU time is what the code costs):
for lagdsl a call of the run made once for the setting (CRun, which a repeated simulate()
calls), for heyoka propagate_grid on the same output times by the integrator made once, for
CyRK nbsolve2_ivp (its C++ DOP853, a numba C callback as right-hand side, cyrk_systems.py)
with t_eval the same times. Each setting is timed once per round, every setting of every tool
in each round, so that the load of a shared machine falls on the tools alike; a time is the
median over the rounds (the ladder's two first calls, a warm-up (CyRK's numba compiles at its
first call) and the one that measures the error, are not counted).
heyoka's compile time (building its integrator, which JIT-compiles the recurrences for the
tolerance's order) is reported apart, as is lagdsl's build (generation, the C compiler and
making the run; the first two are cached by lagdsl across runs).

At matched accuracy: on each method's work-precision curve (its Pareto front), the time to
reach an error level, interpolated linearly in log(time) against log(error) between the two
settings around the level; a level beyond the tightest setting is not reached ("-").

    python benchmarks/heyoka_comparison.py [--rounds N] [--only NAME,...]

Writes benchmarks/heyoka/<problem>.csv and .md (and .png with matplotlib), and the section
between the markers in benchmarks/README.md.
"""
from __future__ import annotations

import benchtools  # noqa: I001  (first: one thread for NumPy)

import argparse
import math
import os
import re
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

import cyrk_systems
import heyoka_systems
import lagdsl
from lagdsl.integrators.registry import OPTIONS
from lagdsl.pipeline import generate
from lagdsl.reference import reference_solution
from lagdsl.run.c_backend import CRun
from lagdsl.run.loading import load as load_library
from lagdsl.scene import Overrides

OUT = benchtools.BENCHMARKS / "heyoka"
README = benchtools.BENCHMARKS / "README.md"
BEGIN, END = "<!-- heyoka_comparison.py: begin -->", "<!-- heyoka_comparison.py: end -->"
LEVELS = (1e-6, 1e-8, 1e-10, 1e-12)
LADDER = tuple(10.0 ** -k for k in range(4, 16))
ECCENTRICITY = 0.6
PERIOD = 2 * math.pi * (1 / (1 - ECCENTRICITY)) ** 1.5
KEPLER = f"""model KeplerE06 "Kepler problem, eccentricity 0.6, from periapsis, GM = 1"
  coordinate r(start = 1.0);
  coordinate theta(start = 0, velocity = {math.sqrt(1 + ECCENTRICITY)!r});
  T = (der(r)^2 + r^2*der(theta)^2)/2;
  U = -1/r;
  scene orbits
    time(stop = {1000 * PERIOD!r}, interval = {PERIOD / 10!r});
    integrator taylor(rtol = 1e-15, atol = 1e-15);
    output r, theta, energy;
  end orbits;
end KeplerE06;
"""


@dataclass(frozen=True)
class Problem:
    name: str
    title: str
    path: Path
    scene: str
    overrides: Overrides
    columns: tuple[str, ...]        # compared with the reference
    methods: tuple[str, ...]        # lagdsl's
    heyoka: object                  # model -> (system, state, column indices)
    cyrk: object                    # model -> (callback address or None, state); heyoka's columns


def problems() -> list[Problem]:
    models = benchtools.MODELS
    kepler = OUT / "kepler_e06_1000.lag"
    kepler.write_text(KEPLER)
    oss_columns = tuple(f"{axis}[{body}]" for body in range(1, 7) for axis in "xyz")
    return [
        Problem("double_pendulum", "chaotic double pendulum, t = 0..20, every 0.5", models / "double_pendulum.lag",
                "chaos", Overrides(stop=20.0, interval=0.5), ("theta1", "theta2"),
                ("taylor", "taylor-state", "dop853"), lambda model: heyoka_systems.double_pendulum(), lambda model: cyrk_systems.double_pendulum()),
        Problem("pleiades", "Pleiades, t = 0..3, every 0.01", models / "pleiades.lag", "stars", Overrides(),
                tuple(f"{axis}[{i}]" for axis in "xy" for i in range(1, 8)),
                ("taylor", "taylor-state", "dop853", "rkn8"),
                lambda model: heyoka_systems.pleiades(), lambda model: cyrk_systems.pleiades()),
        Problem("outer_solar_system", "outer solar system, 10^6 days, every 500 days",
                models / "outer_solar_system.lag", "book", Overrides(stop=1e6), oss_columns,
                ("taylor", "taylor-state", "dop853", "rkn8"), heyoka_systems.outer_solar_system, cyrk_systems.outer_solar_system),
        Problem("kepler", "Kepler e = 0.6, 1000 orbits, every tenth of an orbit", kepler, "orbits", Overrides(),
                ("r", "theta"), ("taylor", "taylor-state", "dop853"), lambda model: heyoka_systems.kepler_polar(ECCENTRICITY),
                lambda model: cyrk_systems.kepler_polar(ECCENTRICITY)),
    ]


OTHERS = ("heyoka", "CyRK")          # the other tools, compared with lagdsl's best method
# lagdsl's methods named apart from their integrator: the integrator and its options beside the tolerances
# (taylor-state: taylor(norm = state), Jorba and Zou's one tolerance for the whole state, as heyoka's).
VARIANTS = {"taylor-state": ("taylor", (("norm", float(OPTIONS["norm"].choices.index("state"))),))}


class OtherToolFailed(Exception):
    """Another tool's integration failed at a setting (the ladder goes on without it)."""


@dataclass(frozen=True)
class Point:
    method: str
    tol: float
    seconds: float
    error: float
    steps: int
    build: float            # lagdsl: generation + compiler; heyoka: constructing (JIT-compiling) the integrator


@dataclass
class Setting:
    """One tool at one tolerance, made (built, compiled) once and timed once per round."""
    method: str
    tol: float
    build: float                            # seconds to make `call` (reported apart)
    call: Callable[[], object]              # one integration; returns its outcome
    judge: Callable[[object], tuple[float, int]]    # outcome -> (error, steps)
    reset: Callable[[], None] = lambda: None        # before a call, untimed (heyoka's initial state)
    times: list[float] = field(default_factory=list)
    outcome: object = None

    def time_once(self) -> None:
        self.reset()
        started = time.process_time()
        self.outcome = self.call()
        self.times.append(time.process_time() - started)

    def point(self) -> Point:
        """The median of the calls timed so far."""
        error_, steps = self.judge(self.outcome)
        return Point(self.method, self.tol, float(np.median(self.times)), error_, steps, self.build)


def lagdsl_setting(model, problem: Problem, method: str, tol: float, reference) -> Setting:
    integrator, options = VARIANTS.get(method, (method, ()))
    plan = model.plan(problem.scene, replace(problem.overrides, integrator=integrator,
                                             options=(("rtol", tol), ("atol", tol), *options)))
    started = time.process_time()
    _, source = generate(model.equations, plan, "c", problem.path.name)
    run = CRun(load_library(source), plan.run_plan())
    build = time.process_time() - started
    indices = [plan.columns.index(c) for c in problem.columns]
    return Setting(method, tol, build, run,
                   lambda result: (error(result.values[:, indices], problem, reference), result.summary.count("accepted")))


def heyoka_setting(model, problem: Problem, tol: float, reference) -> Setting:
    import heyoka as hy
    system, state, columns = problem.heyoka(model)
    started = time.process_time()
    integrator = hy.taylor_adaptive(system, state, tol=tol)
    build = time.process_time() - started
    grid = np.asarray(reference.t, dtype=float)

    def reset() -> None:
        integrator.time, integrator.state[:] = grid[0], state

    def judge(outcome) -> tuple[float, int]:
        values = np.column_stack([outcome[-1][:, columns[c]] for c in problem.columns])
        return error(values, problem, reference), int(outcome[3])
    return Setting("heyoka", tol, build, lambda: integrator.propagate_grid(grid), judge, reset)


def cyrk_setting(model, problem: Problem, tol: float, reference, columns) -> Setting:
    from CyRK import nbsolve2_ivp
    started = time.process_time()
    address, state = problem.cyrk(model)
    build = time.process_time() - started
    grid = np.asarray(reference.t, dtype=float)
    y0 = np.asarray(state, dtype=float)

    def judge(solution) -> tuple[float, int]:
        if not solution.success:
            raise OtherToolFailed(f"CyRK: {solution.message}")
        values = np.column_stack([solution.y[columns[c]] for c in problem.columns])
        return error(values, problem, reference), int(solution.steps_taken)
    return Setting("CyRK", tol, build, lambda: nbsolve2_ivp(address, (grid[0], grid[-1]), y0, method="DOP853",
                                                            t_eval=grid, rtol=tol, atol=tol), judge)


def error(values: np.ndarray, problem: Problem, reference) -> float:
    """The largest absolute difference of `values` (the compared columns) from the reference,
    over the rows; never below the reference's own accuracy."""
    theirs = reference.values[:, [list(reference.columns).index(c) for c in problem.columns]]
    return max(float(np.max(np.abs(values - theirs))), reference.accuracy)


def time_at(points: list[Point], level: float) -> float | None:
    """The time to reach `level` on the curve's Pareto front, log-log interpolated."""
    front, best_error = [], math.inf
    for point in sorted(points, key=lambda p: p.seconds):
        if point.error < best_error:
            front.append(point)
            best_error = point.error
    reached = [p for p in front if p.error <= level]
    if not reached:
        return None
    first = reached[0]
    before = [p for p in front if p.seconds < first.seconds and p.error > level]
    if not before:
        return first.seconds
    last = before[-1]
    weight = (math.log(last.error) - math.log(level)) / (math.log(last.error) - math.log(first.error))
    return math.exp(math.log(last.seconds) + weight * (math.log(first.seconds) - math.log(last.seconds)))


def ladder(make: Callable[[float], Setting], tolerances, limit: float) -> list[Setting]:
    """The settings of one method, loosest first, each called twice (a warm-up, then its error);
    stops after a call slower than `limit` seconds."""
    settings = []
    for tol in tolerances:
        try:
            setting = make(tol)
            setting.time_once()
            setting.times.clear()
            setting.time_once()
            point = setting.point()
        except (lagdsl.SimulationError, OtherToolFailed) as failure:
            print(f"    tol {tol:g}: failed: {failure}", file=sys.stderr)
            continue
        settings.append(setting)
        print(f"    {point.method} tol {tol:g}: {benchtools.seconds(point.seconds)}, error {point.error:.2g}, "
              f"{point.steps} steps (build {benchtools.seconds(point.build)})", file=sys.stderr, flush=True)
        if point.seconds > limit:
            break
    return settings


def timed_in_rounds(ladders: dict[str, list[Setting]], rounds: int) -> dict[str, list[Point]]:
    """Every setting of every method timed once per round, the methods taking turns at each
    tolerance; the curves of medians."""
    settings = sorted((s for ladder_ in ladders.values() for s in ladder_), key=lambda s: -s.tol)
    for setting in settings:
        setting.times.clear()
    for _ in range(rounds):
        for setting in settings:
            setting.time_once()
    return {method: [s.point() for s in ladder_] for method, ladder_ in ladders.items()}


def section(problem: Problem, reference, curves: dict[str, list[Point]]) -> str:
    methods = list(curves)
    others = [m for m in OTHERS if m in curves]
    headers = ["error <=", *methods, *(f"{m} / best lagdsl" for m in others)]
    rows = []
    for level in LEVELS:
        times = {m: time_at(curves[m], level) for m in methods}
        lagdsl_times = [t for m, t in times.items() if m not in OTHERS and t is not None]
        best = min(lagdsl_times) if lagdsl_times else None
        rows.append([f"{level:g}", *(benchtools.seconds(times[m]) if times[m] else "-" for m in methods),
                     *(benchtools.ratio(times.get(m), best) for m in others)])
    compile_times = ", ".join(f"{p.tol:g}: {benchtools.seconds(p.build)}" for p in curves.get("heyoka", []))
    builds = ", ".join(f"{m} {benchtools.seconds(curves[m][0].build)}" for m in methods if m not in OTHERS and curves[m])
    return "\n".join([
        f"### {problem.title}", "", f"![{problem.name}](heyoka/{problem.name}.png)", "",
        f"{reference.describe()}. Compared columns: {', '.join(problem.columns)}.", "",
        "CPU time of the integration at matched accuracy (interpolated on each curve):", "",
        benchtools.markdown_table(headers, rows), "",
        f"heyoka's integrator construction (JIT compilation) per tolerance: {compile_times}.",
        f"lagdsl's generation and C build, first setting (cached afterwards): {builds}.", ""])


def write_outputs(problem: Problem, text: str, curves: dict[str, list[Point]]) -> None:
    lines = ["method,tol,seconds,error,steps,build"]
    lines += [f"{p.method},{p.tol!r},{p.seconds!r},{p.error!r},{p.steps},{p.build!r}"
              for points in curves.values() for p in points]
    (OUT / f"{problem.name}.csv").write_text("\n".join(lines) + "\n")
    (OUT / f"{problem.name}.md").write_text(text)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    figure, axes = plt.subplots(figsize=(6, 4))
    for method, points in curves.items():
        axes.loglog([p.error for p in points], [p.seconds for p in points], "o-", label=method)
    axes.set_xlabel("max abs error")
    axes.set_ylabel("CPU seconds")
    axes.set_title(problem.title, fontsize=9)
    axes.invert_xaxis()
    axes.legend()
    figure.tight_layout()
    figure.savefig(OUT / f"{problem.name}.png", dpi=100)
    plt.close(figure)


def write_readme(names: list[str], load: str) -> None:
    parts = [(OUT / f"{name}.md").read_text() for name in names if (OUT / f"{name}.md").exists()]
    intro = ["## Taylor against heyoka and CyRK (`heyoka_comparison.py`)", "",
             f"Measured {time.strftime('%Y-%m-%d %H:%M')} on {benchtools.machine_description()}; heyoka "
             f"{_version('heyoka')}, CyRK {_version('CyRK')}; load average {load} when this section was written. "
             "See the script's docstring for the method. `taylor`, `taylor-state` (taylor(norm = state)), `dop853` "
             "and `rkn8` are lagdsl's C backend; "
             "CyRK is `nbsolve2_ivp` (its C++ DOP853). A ratio below 1 in the last columns: the other tool "
             "takes less time than lagdsl's best method at that error.", ""]
    text = "\n".join([BEGIN, *intro, "\n".join(parts).rstrip("\n"), "", END]) + "\n"
    readme = README.read_text()
    if BEGIN in readme:
        readme = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END) + "\n?", lambda _: text, readme, flags=re.S)
    else:
        readme = readme.rstrip("\n") + "\n\n" + text
    README.write_text(readme)


def _version(package: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(package)
    except PackageNotFoundError:
        return "not installed"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=7,
                        help="rounds, each timing every setting once; the median counts (default 7)")
    parser.add_argument("--limit", type=float, default=5.0, help="CPU seconds after which a ladder stops")
    parser.add_argument("--only", help="comma-separated problem names")
    arguments = parser.parse_args()
    benchtools.pin_to_one_core()
    OUT.mkdir(exist_ok=True)
    chosen = problems()
    for problem in chosen:
        if arguments.only and problem.name not in arguments.only.split(","):
            continue
        print(f"{problem.title}:", file=sys.stderr, flush=True)
        model = lagdsl.load(problem.path)
        reference = reference_solution(model.equations, model.plan(problem.scene, problem.overrides),
                                       problem.path.name)
        print(f"  {reference.describe()}", file=sys.stderr, flush=True)
        ladders = {method: ladder(lambda tol, m=method: lagdsl_setting(model, problem, m, tol, reference),
                                  LADDER, arguments.limit)
                   for method in problem.methods}
        ladders["heyoka"] = ladder(lambda tol: heyoka_setting(model, problem, tol, reference), LADDER, arguments.limit)
        columns = problem.heyoka(model)[2]
        ladders["CyRK"] = ladder(lambda tol: cyrk_setting(model, problem, tol, reference, columns),
                                 LADDER, arguments.limit)
        curves = timed_in_rounds(ladders, arguments.rounds)
        text = section(problem, reference, curves)
        print(text, flush=True)
        write_outputs(problem, text, curves)
        write_readme([p.name for p in chosen], ", ".join(f"{v:.1f}" for v in os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
