"""`lagc run`: simulate a scene; the CSV on standard output (or -o), the run summary on stderr."""
from __future__ import annotations

import contextlib
import sys

from ..errors import SimulationError, SimulationInterrupted
from ..progress import TimeProgress
from ..run import cache
from ..run.files import write_output
from ..source import SourceFile
from . import common


def add(commands) -> None:
    run_parser = commands.add_parser("run", help="simulate a scene; CSV on stdout (or -o), run summary on stderr")
    run_parser.add_argument("model")
    common.scene_options(run_parser)
    common.run_options(run_parser)
    run_parser.add_argument("--units", action="store_true", help="name each column's unit in the CSV header: 'x [m]'")
    run_parser.add_argument("-o", "--output", help="write the CSV here instead of standard output")
    run_parser.add_argument("--no-cache", action="store_true",
                     help="build in a private temporary directory; use nothing from the build cache")
    run_parser.add_argument("--error", action="store_true",
                     help="estimate the run's global error (a 100x tighter rerun, or the extended-precision reference)")
    run_parser.add_argument("--plot", metavar="FILE.png", help="plot the output columns against time")
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
    # --units names the columns' units and --error needs the model: the full pipeline
    stored = None if arguments.units or arguments.error else plans.find(source, arguments.scene, arguments.backend,
                                                                        arguments.integrator)
    model = None if stored else common.load_model(source)      # the model's errors first, as always
    common.check_destinations(arguments.model, arguments.output, arguments.plot)
    overrides = common.overrides(arguments)
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
        from .. import plots
        write_output(arguments.plot, plots.outputs_png(result, _title(source, arguments.scene)))
    print(result.summary.render(), file=sys.stderr)
    return 0


def _title(source: SourceFile, scene: str | None) -> str:
    return f"{source.name}, scene {scene}" if scene else source.name


def _incomplete(partial, time: float, output: str | None) -> str:
    where = output or "standard output"
    rows = f"{len(partial.t)} rows up to t = {partial.t[-1]:.17g}" if len(partial.t) else "no rows"
    return f"the run is incomplete: it stopped at t = {time:.17g}; {rows} written to {where}"
