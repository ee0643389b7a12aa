"""`lagc bench`: work against precision, each integrator's time and global error against an
extended-precision reference."""
from __future__ import annotations

from ..run.files import write_output
from ..settings import Overrides
from ..source import SourceFile
from . import common


def add(commands) -> None:
    bench_parser = commands.add_parser("bench", help="work against precision: each integrator's time and global error "
                                "against an extended-precision reference")
    bench_parser.add_argument("model")
    common.scene_options(bench_parser)
    bench_parser.add_argument("--integrators", metavar="LIST",
                       help="comma-separated integrators to compare (default: all the scene admits)")
    bench_parser.add_argument("--backend", default="c", metavar="c|numpy|both", help="generated code to run (default: c)")
    bench_parser.add_argument("--peers", action="store_true",
                       help="also scipy's solve_ivp (RK45, DOP853, Radau, LSODA) and CyRK (if installed)")
    bench_parser.add_argument("--repeat", default="3", metavar="N", help="runs per setting, the fastest counts (default: 3)")
    common.input_options(bench_parser)
    bench_parser.add_argument("-o", "--output", metavar="TABLE.csv", help="write the table as CSV")
    bench_parser.add_argument("--plot", metavar="FILE.png", help="write the work-precision diagram and the drifts")
    bench_parser.set_defaults(handler=run)



def run(arguments) -> int:
    """The table on standard output (the reference first), -o CSV and --plot PNG, a progress bar on stderr."""
    from .. import bench, plots
    if arguments.backend not in bench.BACKEND_CHOICES:
        common.refuse("--backend", f"expected c, numpy or both, got '{arguments.backend}'")
    repeat = common.positive_integer("--repeat", arguments.repeat)
    integrators = common.integrator_list(arguments.integrators)
    common.check_destinations(arguments.model, arguments.output, arguments.plot)
    model = common.load_model(SourceFile.read(arguments.model))
    overrides = Overrides(common.set_values(arguments.set, with_units=True), arguments.start, arguments.stop,
                          arguments.interval)
    progress = bench.progress_bar()
    try:
        report = bench.run_bench(model, arguments.scene, overrides, integrators, bench.backends(arguments.backend),
                                 arguments.peers, repeat, drift=bool(arguments.plot), progress=progress)
    finally:
        progress.close()
    common.deliver(report.render() + "\n", None)
    if arguments.output is not None:
        write_output(arguments.output, report.csv())
    if arguments.plot is not None:
        write_output(arguments.plot, plots.work_precision_png(report))
    return 0
