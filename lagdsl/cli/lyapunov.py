"""`lagc lyapunov`: Lyapunov exponents of a scene's motion (sensitivity/lyapunov.py).

Bad input (a model's error, an unknown scene, a stop time not after the start, a model with
nothing to integrate) exits 2, a numerical failure 1, as `lagc modes` does.
"""
from __future__ import annotations

from ..progress import TimeProgress
from ..settings import given_options
from ..source import SourceFile
from . import common
from .modes import BAD_INPUT_EXIT, exit_statuses


def add(commands) -> None:
    parser = commands.add_parser(
        "lyapunov", help="the largest Lyapunov exponent, or the whole spectrum (--all), from the variational "
                         "equations",
        description="Integrate tangent vectors with the state through the generated variational equations "
                    "(NumPy or C backend; on the constraint manifold of a constrained model) and "
                    "re-orthonormalise them at a fixed interval (Benettin's method). "
                    "Prints the exponents in 1/s, each with the fit log|v| = a + b log t + lambda t of its record, "
                    "which tells exponential from algebraic growth (docs/numerics.md); for a Hamiltonian "
                    "model with --all, the pair sums "
                    "lambda_i + lambda_(2n+1-i) and the two exponents nearest zero. Exit status 2 for bad input, "
                    "1 for a numerical failure.")
    parser.usage_exit = BAD_INPUT_EXIT
    parser.add_argument("model")
    common.scene_options(parser)
    parser.add_argument("--start", type=lambda text: common.time_value("--start", text),
                        help="start time: seconds, or a number and a unit of time (default: the scene's)")
    parser.add_argument("--stop", type=lambda text: common.time_value("--stop", text),
                        help="stop time: seconds, or a number and a unit of time (default: the scene's)")
    parser.add_argument("--all", action="store_true", help="the whole spectrum (2n tangent vectors, QR) instead "
                                                           "of the largest exponent alone")
    parser.add_argument("--renormalise", type=lambda text: common.time_value("--renormalise", text),
                        metavar="TAU", help="seconds between two re-orthonormalisations (default 1 s)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter or a start value (q.start, q.velocity); a number in SI, or "
                             "with a unit ('30 deg')")
    common.integrator_options(parser)
    parser.add_argument("--backend", choices=("c", "numpy"), default="numpy",
                        help="generated code that carries the state and the tangent vectors (default: numpy)")
    parser.add_argument("-o", metavar="CONV.csv", dest="file",
                        help="write the convergence record: t and each exponent's running estimate")
    parser.add_argument("--plot", metavar="CONV.png", help="plot the running estimates against t (matplotlib)")
    parser.set_defaults(handler=exit_statuses(run))


def run(arguments) -> int:
    common.check_destinations(arguments.model, arguments.file, arguments.plot)
    model = common.load_model(SourceFile.read(arguments.model))
    progress = TimeProgress()
    try:
        spectrum = model.lyapunov(arguments.scene, start=arguments.start, stop=arguments.stop, all=arguments.all,
                                  renormalise=arguments.renormalise,
                                  set=dict(common.set_values(arguments.set, with_units=True)),
                                  integrator=arguments.integrator, backend=arguments.backend, progress=progress,
                                  **dict(given_options(vars(arguments))))
    finally:
        progress.close()
    print(spectrum.render(), end="")
    if arguments.file is not None:
        common.deliver(spectrum.to_csv(), arguments.file)
    if arguments.plot is not None:
        from ..plots import lyapunov_png
        from ..run.files import write_output
        write_output(arguments.plot, lyapunov_png(spectrum))
    return 0
