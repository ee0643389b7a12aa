"""The `lagc` command: a thin layer over the Python API.

This is the only place that catches LagError: it prints `file:line:column: error: ...`
with the source line and a caret, and exits 1. Anything else escaping is a bug in lagdsl.
Ctrl-C exits 130 (128 + SIGINT, as shells report it) without a traceback; during `lagc run`
the rows computed so far are written and the summary says where the run stopped.

`lagc run` first looks for the scene's stored plan (run/plans.py): a warm run imports neither
sympy nor lark, so the pipeline (api, present) is imported only by the commands that need it.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time as clock
import warnings


from . import __version__
from .errors import LagError, LagWarning, Setting, SimulationError, SimulationInterrupted, suggest
from .escape import visible
from .run import cache
from .run.output import check_writable, write_output
from .settings import INTEGRATORS, Overrides, given_options
from .source import SourceFile


INTERRUPTED_EXIT = 130


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default", LagWarning)
            warnings.showwarning = _show_warning
            return _dispatch(argv)
    except KeyboardInterrupt:
        print("lagc: interrupted", file=sys.stderr)
        return INTERRUPTED_EXIT
    except LagError as error:
        print(error.render(), file=sys.stderr)
        return 1
    except SimulationError as error:
        print(error.render(), file=sys.stderr)
        return 1
    except BrokenPipeError:
        # The reader went away (`lagc eom model.lag | head`): stop quietly, as Unix tools do.
        sys.stdout = open(os.devnull, "w")
        return 0
    except OSError as error:
        where = f": {visible(str(error.filename))}" if error.filename else ""
        print(f"lagc: error: {error.strerror}{where}", file=sys.stderr)
        return 1


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"lagc: warning: {message}", file=sys.stderr)


def _dispatch(argv: list[str]) -> int:
    parser = _parser()
    if argv and argv[0] not in ("check", "eom", "run", "sweep", "bench", "cache", "-h", "--help", "--version") \
            and "--emit" in argv:
        argv = ["emit", *argv]
    arguments = parser.parse_args(argv)
    return arguments.handler(arguments)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="lagc", description="Compile Lagrangian models (.lag) to equations of motion, code and simulations.",
        epilog="Write `lagc MODEL.lag --emit c|numpy [-o FILE] [--scene S]` to emit source code.")
    parser.add_argument("--version", action="version", version=f"lagc {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    check = commands.add_parser("check", help="validate a model; print degrees of freedom, constraints, conserved quantities, scenes")
    check.add_argument("model")
    check.set_defaults(handler=_check)

    eom = commands.add_parser("eom", help="print the derived equations of motion")
    eom.add_argument("model")
    eom.add_argument("--latex", action="store_true", help="print LaTeX (an aligned environment)")
    eom.set_defaults(handler=_eom)

    run = commands.add_parser("run", help="simulate a scene; CSV on stdout (or -o), run summary on stderr")
    run.add_argument("model")
    _scene_options(run)
    _run_options(run)
    run.add_argument("--units", action="store_true", help="name each column's unit in the CSV header: 'x [m]'")
    run.add_argument("-o", "--output", help="write the CSV here instead of standard output")
    run.add_argument("--no-cache", action="store_true",
                     help="build in a private temporary directory; use nothing from the build cache")
    run.add_argument("--error", action="store_true",
                     help="estimate the run's global error (a 100x tighter rerun, or the extended-precision reference)")
    run.add_argument("--plot", metavar="FILE.png", help="plot the output columns against time")
    run.set_defaults(handler=_run)

    sweep = commands.add_parser("sweep", help="simulate many members (a grid or a random sample of inputs); "
                                "one tidy table to -o")
    sweep.add_argument("model")
    _scene_options(sweep)
    _run_options(sweep)
    sweep.add_argument("--vary", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                       help="COUNT values from START to STOP; several --vary make the grid of all combinations")
    sweep.add_argument("--random", action="append", default=[], metavar="NAME=LOW:HIGH",
                       help="uniform random values in [LOW, HIGH), -n of them (instead of --vary)")
    sweep.add_argument("-n", type=int, dest="count", metavar="N", help="members of a --random sample")
    sweep.add_argument("--seed", type=int, default=0, help="seed of the --random sample (default 0)")
    sweep.add_argument("--workers", type=int, help="threads (default: OMP_NUM_THREADS, else every CPU); "
                       "with --dask local, worker processes")
    sweep.add_argument("--dask", metavar="ADDRESS|local",
                       help="run on the Dask scheduler at ADDRESS, or on a local cluster of processes")
    sweep.add_argument("-o", "--output", required=True,
                       help="the table: Parquet if the name ends in .parquet (needs pyarrow), else CSV")
    sweep.set_defaults(handler=_sweep)
    bench = commands.add_parser("bench", help="work against precision: each integrator's time and global error "
                                "against an extended-precision reference")
    bench.add_argument("model")
    _scene_options(bench)
    bench.add_argument("--integrators", metavar="LIST",
                       help="comma-separated integrators to compare (default: all the scene admits)")
    bench.add_argument("--backend", default="c", metavar="c|numpy|both", help="generated code to run (default: c)")
    bench.add_argument("--peers", action="store_true",
                       help="also scipy's solve_ivp (RK45, DOP853, Radau, LSODA) and CyRK (if installed)")
    bench.add_argument("--repeat", default="3", metavar="N", help="runs per setting, the fastest counts (default: 3)")
    _input_options(bench)
    bench.add_argument("-o", "--output", metavar="TABLE.csv", help="write the table as CSV")
    bench.add_argument("--plot", metavar="FILE.png", help="write the work-precision diagram and the drifts")
    bench.set_defaults(handler=_bench)

    cache_command = commands.add_parser("cache", help="show where the build cache is and its size, or empty it")
    cache_command.add_argument("action", choices=("info", "clear"))
    cache_command.set_defaults(handler=_cache)

    emit = commands.add_parser("emit", help="write the generated source: lagc MODEL --emit c|numpy [-o FILE]")
    emit.add_argument("model")
    emit.add_argument("--emit", required=True, choices=("c", "numpy"), dest="language")
    _scene_options(emit)
    emit.add_argument("-o", "--output", help="file to write (default: standard output)")
    emit.set_defaults(handler=_emit)
    return parser


def _run_options(parser: argparse.ArgumentParser) -> None:
    """What `lagc run` and `lagc sweep` take: the backend, the inputs and the integrator's options."""
    parser.add_argument("--backend", choices=("c", "numpy"), default="c", help="generated code to run (default: c)")
    _input_options(parser)
    parser.add_argument("--integrator", help="rk4, dopri5, dop853, rkn8, radau5, gauss or auto")
    parser.add_argument("--rtol", type=float, help="relative tolerance (adaptive integrators)")
    parser.add_argument("--atol", type=float, help="absolute tolerance (adaptive integrators)")
    parser.add_argument("--step", type=float, help="step size (rk4, gauss)")
    parser.add_argument("--stages", type=int, help="number of stages (gauss)")
    parser.add_argument("--max-step", type=float, help="largest step (dopri5, dop853, rkn8, radau5)")
    parser.add_argument("--max-steps", type=int, help="step limit, accepted + rejected "
                        "(default: 100000, or 100 per output row if that is more)")


def _scene_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", help="scene to use (default: the model's first scene)")


def _input_options(parser: argparse.ArgumentParser) -> None:
    """Parameters, initial values and the time grid: the inputs of a run."""
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter, or an initial value as COORDINATE.start / COORDINATE.velocity")
    parser.add_argument("--start", type=float, help="start time of the output grid")
    parser.add_argument("--stop", type=float, help="stop time")
    parser.add_argument("--interval", type=float, help="output interval")


def _overrides(arguments) -> Overrides:
    options = given_options(vars(arguments))
    return Overrides(_set_values(arguments.set), arguments.start, arguments.stop, arguments.interval,
                     arguments.integrator, options)


def _set_values(items: list[str]) -> tuple[tuple[str, float], ...]:
    values = []
    for item in items:
        name, equals, text = item.partition("=")
        try:
            value = float(text)
        except ValueError:
            value = None
        if not equals or value is None:
            raise LagError(f"--set takes NAME=VALUE with a number, got '{item}'")
        values.append((name.strip(), value))
    return tuple(values)


def _run(arguments) -> int:
    """Simulate; on a numerical failure deliver the rows computed so far, say where the run
    stopped, and exit 1 (with the error, which `main` prints). --no-cache: in a private cache.

    With a stored plan of the scene (run/plans.py) the model is neither parsed nor derived,
    unless the plan cannot serve the overrides (or --error needs the model); the output is the same
    either way."""
    with cache.private_cache() if arguments.no_cache else contextlib.nullcontext():
        return _simulate(arguments)


def _simulate(arguments) -> int:
    """`lagc run` in the cache in use: warm from a stored plan if it serves, else the full pipeline."""
    from .run import plans      # numpy and the runner: only `lagc run` needs them
    source = SourceFile.read(arguments.model)
    # --units names the columns' units and --error needs the model: the full pipeline
    stored = None if arguments.units or arguments.error else plans.find(source, arguments.scene, arguments.backend,
                                                                        arguments.integrator)
    model = None if stored else _model(source)      # the model's errors first, as always
    _check_destinations(arguments.output, arguments.plot)
    overrides = _overrides(arguments)
    progress = ProgressLine(sys.stderr)
    units = model.column_units(arguments.scene) if arguments.units else None
    try:
        plan = stored.resolve(overrides) if stored else None
        result = stored.run(plan, progress.show) if plan else None
        if result is None:
            model = model if model is not None else _model(source)
            result = model.simulate_plan(arguments.scene, arguments.backend, overrides, progress.show,
                                         arguments.error)
    except SimulationInterrupted as stopped:
        progress.clear()
        _deliver(stopped.partial.csv(units), arguments.output)
        print(stopped.partial.summary.render(), file=sys.stderr)
        print(f"lagc: {stopped.render()}, after {len(stopped.partial.t)} rows", file=sys.stderr)
        return INTERRUPTED_EXIT
    except SimulationError as error:
        progress.clear()
        if error.partial is not None:
            _deliver(error.partial.csv(units), arguments.output)
            print(error.partial.summary.render(), file=sys.stderr)
            print(_incomplete(error.partial, error.time, arguments.output), file=sys.stderr)
        raise
    progress.clear()
    _deliver(result.csv(units), arguments.output)
    if arguments.plot:
        from . import plots
        write_output(arguments.plot, plots.outputs_png(result, _title(source, arguments.scene)))
    print(result.summary.render(), file=sys.stderr)
    return 0


def _sweep(arguments) -> int:
    """Run the members of a grid or random sample; write the tidy table and the summary. Members
    that fail are rows with their status; Ctrl-C writes the members finished so far."""
    from .run.sweep import RUN_KEYWORDS, sweep_table, sweep_values
    model = _model(SourceFile.read(arguments.model))
    check_writable(arguments.output)
    varied = sweep_values(arguments.vary, arguments.random, arguments.count, arguments.seed)
    overrides = _overrides(arguments)
    keywords = {k: getattr(arguments, k) for k in RUN_KEYWORDS if getattr(arguments, k) is not None}
    with _dask_client(arguments.dask, arguments.workers) as client:
        try:
            sweep = model.sweep(arguments.scene, arguments.backend, set={**dict(overrides.values), **varied},
                                workers=None if client else arguments.workers, client=client,
                                progress=sys.stderr.isatty(),
                                **keywords)
        except SimulationInterrupted as stopped:
            write_output(arguments.output, sweep_table(stopped.partial, arguments.output))
            print(stopped.partial.summary.render(), file=sys.stderr)
            print(f"lagc: interrupted; the table in {arguments.output} has every member, those not finished "
                  "with status 'interrupted'", file=sys.stderr)
            return INTERRUPTED_EXIT
    write_output(arguments.output, sweep_table(sweep, arguments.output))
    print(sweep.summary.render(), file=sys.stderr)
    return 0


@contextlib.contextmanager
def _dask_client(address: str | None, workers: int | None):
    """A dask.distributed Client for --dask (None without it): `local` starts a LocalCluster of
    worker processes here, any other value is a scheduler's address."""
    if address is None:
        yield None
        return
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise LagError("--dask needs dask.distributed: pip install 'lagdsl[sweep]'", Setting("--dask")) from None
    if address == "local":
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            yield client
        return
    try:
        client = Client(address, timeout="10s")
    except (OSError, ValueError, TypeError) as error:
        raise LagError(f"cannot reach the Dask scheduler at '{address}': {error}", Setting("--dask")) from None
    with client:
        yield client


def _title(source: SourceFile, scene: str | None) -> str:
    return f"{source.name}, scene {scene}" if scene else source.name


class ProgressLine:
    """`lagc: t = 12.5 of 50 (25%), 3.1 s` on a terminal's standard error, rewritten in place with \r
    at most every REFRESH seconds once a run has taken DELAY seconds; nothing on a file or pipe
    (logs stay clean). `clear` erases it before the summary."""

    DELAY = 2.0
    REFRESH = 0.25

    def __init__(self, stream):
        self.stream = stream
        self.active = hasattr(stream, "isatty") and stream.isatty()
        self.started = clock.monotonic()
        self.shown = 0.0          # when the line was last written, 0: never
        self.width = 0

    def show(self, t: float, start: float, stop: float) -> None:
        now = clock.monotonic()
        if not self.active or now - self.started < self.DELAY or now - self.shown < self.REFRESH:
            return
        share = 100 * (t - start) / (stop - start)
        text = f"lagc: t = {t:.6g} of {stop:.6g} ({share:.0f}%), {now - self.started:.1f} s"
        self.stream.write("\r" + text.ljust(self.width))
        self.stream.flush()
        self.width, self.shown = len(text), now

    def clear(self) -> None:
        if self.shown:
            self.stream.write("\r" + " " * self.width + "\r")
            self.stream.flush()
            self.shown = 0.0


def _incomplete(partial, time: float, output: str | None) -> str:
    where = output or "standard output"
    rows = f"{len(partial.t)} rows up to t = {partial.t[-1]:.17g}" if len(partial.t) else "no rows"
    return f"the run is incomplete: it stopped at t = {time:.17g}; {rows} written to {where}"


def _bench(arguments) -> int:
    """The table on standard output (the reference first), -o CSV and --plot PNG, a progress bar on stderr."""
    from . import bench, plots
    if arguments.backend not in bench.BACKEND_CHOICES:
        _refuse("--backend", f"expected c, numpy or both, got '{arguments.backend}'")
    repeat = _positive_integer("--repeat", arguments.repeat)
    integrators = _integrator_list(arguments.integrators)
    _check_destinations(arguments.output, arguments.plot)
    model = _model(SourceFile.read(arguments.model))
    overrides = Overrides(_set_values(arguments.set), arguments.start, arguments.stop, arguments.interval)
    progress = bench.progress_bar()
    try:
        report = bench.run_bench(model, arguments.scene, overrides, integrators, bench.backends(arguments.backend),
                                 arguments.peers, repeat, drift=bool(arguments.plot), progress=progress)
    finally:
        progress.close()
    print(report.render())
    if arguments.output:
        write_output(arguments.output, report.csv())
    if arguments.plot:
        write_output(arguments.plot, plots.work_precision_png(report))
    return 0


def _check_destinations(output: str | None, plot: str | None) -> None:
    """Refuse before the run, not after it: a path that cannot be written, a plot without matplotlib."""
    for path in (output, plot):
        if path:
            check_writable(path)
    if plot:
        from . import plots     # it imports sympy, which a warm `lagc run` does without
        plots.require_matplotlib()


def _refuse(option: str, message: str):
    raise LagError(message, Setting(option))


def _positive_integer(option: str, text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    return value if value >= 1 else _refuse(option, f"expected a whole number >= 1, got '{text}'")


def _integrator_list(text: str | None) -> tuple[str, ...] | None:
    if text is None:
        return None
    names = tuple(name.strip() for name in text.split(",") if name.strip())
    for name in names:
        if name not in INTEGRATORS:
            _refuse("--integrators", f"unknown integrator '{name}'{suggest(name, INTEGRATORS)} "
                    f"(available: {', '.join(INTEGRATORS)})")
    return names or _refuse("--integrators", "expected a comma-separated list of integrators")


def _model(source: SourceFile):
    """The model parsed and derived: the pipeline (sympy, lark) is imported only here."""
    from .api import Model
    return Model(source)


def _emit(arguments) -> int:
    _deliver(_model(SourceFile.read(arguments.model)).emit(arguments.language, arguments.scene).text,
             arguments.output)
    return 0


def _deliver(text: str, output: str | None) -> None:
    """To the -o file (see `write_output`), or to standard output."""
    if output:
        write_output(output, text)
    else:
        sys.stdout.write(text)


def _check(arguments) -> int:
    from .present import describe_model
    model = _model(SourceFile.read(arguments.model))
    for note in model.ir.units.notes if model.ir.units else ():
        print(note.render(), file=sys.stderr)
    print(describe_model(model.ir, model.equations))
    return 0


def _eom(arguments) -> int:
    from .mechanics.families import expanded
    from .present import format_equations
    print(format_equations(expanded(_model(SourceFile.read(arguments.model)).equations), latex=arguments.latex))
    return 0


def _cache(arguments) -> int:
    """`lagc cache info`: where the cache is, how many entries and bytes; `lagc cache clear`: empty it."""
    where = visible(cache.cache_root())
    if arguments.action == "clear":
        print(f"removed {cache.clear()} entries from the build cache {where}")
    else:
        entries, size = cache.usage()
        print(f"build cache {where}: {entries} entries, {size / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
