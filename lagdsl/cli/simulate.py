"""`lagc run`: simulate a scene; the CSV on standard output (or -o), the run summary on stderr."""
from __future__ import annotations

import contextlib
import sys

from ..errors import SimulationError, SimulationInterrupted
from ..progress import TimeProgress
from ..run import cache
from ..source import SourceFile
from . import common


def add(commands) -> None:
    run_parser = common.run_command(commands, "run", "simulate a scene; CSV on stdout (or -o), run summary on stderr")
    run_parser.add_argument("--units", action="store_true", help="name each column's unit in the CSV header: 'x [m]'")
    run_parser.add_argument("-o", "--output", help="write the CSV here instead of standard output")
    run_parser.add_argument("--no-cache", action="store_true",
                     help="build in a private temporary directory; use nothing from the build cache")
    run_parser.add_argument("--error", action="store_true",
                     help="estimate the run's global error (a 100x tighter rerun, or the extended-precision reference)")
    run_parser.add_argument("--plot", metavar="FILE.png",
                            help="plot the output columns against time (each axis with its unit)")
    run_parser.add_argument("--plot-xy", metavar="X,Y",
                            help="with --plot: plot column Y against column X instead (a trajectory: x,y)")
    run_parser.set_defaults(handler=run)



def run(arguments) -> int:
    """Simulate; on a numerical failure deliver the rows computed so far, say where the run
    stopped, and exit 1 (with the error, which `main` prints). --no-cache: in a private cache.

    With a stored plan of the scene (run/plans.py) the model is neither parsed nor derived,
    unless the plan cannot serve the overrides (or --error needs the model); the output is the same
    either way."""
    with cache.private_cache() if arguments.no_cache else contextlib.nullcontext():
        return _simulate(arguments)


def _simulate(arguments) -> int:
    """`lagc run` in the cache in use: warm from a stored plan if it serves, else the full pipeline."""
    from ..run import plans      # numpy and the runner: only `lagc run` needs them
    source = SourceFile.read(arguments.model)
    # --units and --plot name the columns' units and --error needs the model: the full pipeline
    full = arguments.units or arguments.error or arguments.plot is not None
    # -o and --plot refused before the model is derived (which can take long) or run
    common.check_destinations(arguments.model, arguments.output, arguments.plot)
    stored = None if full else plans.find(source, arguments.scene, arguments.backend, arguments.integrator)
    model = None if stored else common.load_model(source)
    overrides = common.overrides(arguments)
    xy = _trajectory(arguments, model)
    progress = TimeProgress()
    units = model.column_units(arguments.scene) if arguments.units else None
    try:
        plan = stored.resolve(overrides) if stored else None
        result = stored.run(plan, progress) if plan else None
        if result is None:
            model = model if model is not None else common.load_model(source)
            result = model.simulate_plan(arguments.scene, arguments.backend, overrides, progress,
                                         arguments.error)
    except SimulationInterrupted as stopped:
        progress.close()
        common.deliver(stopped.partial.csv(units), arguments.output)
        print(stopped.partial.summary.render(), file=sys.stderr)
        print(f"lagc: {stopped.render()}, after {len(stopped.partial.t)} rows", file=sys.stderr)
        return common.interrupted_exit()
    except SimulationError as error:
        progress.close()
        if error.partial is not None:
            common.deliver(error.partial.csv(units), arguments.output)
            print(error.partial.summary.render(), file=sys.stderr)
            print(_incomplete(error.partial, error.time, arguments.output), file=sys.stderr)
        raise
    progress.close()
    common.deliver(result.csv(units), arguments.output)
    if arguments.plot is not None:
        result.plot(arguments.plot, xy)
    print(result.summary.render(), file=sys.stderr)
    return 0


def _trajectory(arguments, model) -> tuple[str, str] | None:
    """--plot-xy X,Y as (X, Y), checked against the scene's columns before the run."""
    if arguments.plot_xy is None:
        return None
    if arguments.plot is None:
        common.refuse("--plot-xy", "needs --plot FILE.png, the figure to draw the trajectory in")
    names = tuple(name.strip() for name in arguments.plot_xy.split(","))
    if len(names) != 2 or not all(names):
        common.refuse("--plot-xy", f"expected two columns X,Y, got '{arguments.plot_xy}'")
    from ..plots import check_columns
    check_columns(model.plan(arguments.scene).columns, names)
    return names


def _incomplete(partial, time: float, output: str | None) -> str:
    where = output or "standard output"
    rows = f"{len(partial.t)} rows up to t = {partial.t[-1]:.17g}" if len(partial.t) else "no rows"
    return f"the run is incomplete: it stopped at t = {time:.17g}; {rows} written to {where}"
