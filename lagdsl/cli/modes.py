"""`lagc modes` and `lagc linearize`: the linear analysis of a model about a state.

These two commands exit with status 2 for bad input (a model's error, an option naming no
coordinate, parameter or output, a state off the constraints) and 1 for a numerical failure (no
equilibrium near the guess, a mass matrix singular at the point), as the analysis tools they
stand beside do; the message is the same located one either way.
"""
from __future__ import annotations

import functools
import sys

from ..errors import AnalysisError, LagError
from ..run import answers
from ..run.files import check_writable, write_output
from ..source import SourceFile
from . import common

BAD_INPUT_EXIT = 2
NUMERICAL_FAILURE_EXIT = 1
PLOTTED_MODES = 10


def add(commands) -> None:
    modes_parser = commands.add_parser("modes", help="equilibrium, natural frequencies, damping, mode shapes and "
                                                     "stability about a state")
    _point_options(modes_parser)
    modes_parser.add_argument("-o", "--output", metavar="FILE.csv",
                              help="write the modes as CSV (mode, real, imag, omega, frequency_hz, damping_ratio, "
                                   "verdict, one column per coordinate)")
    modes_parser.add_argument("--plot", metavar="FILE.png", help="plot the mode shapes")
    modes_parser.add_argument("--count", default=str(PLOTTED_MODES),
                              help=f"modes to plot (default: the lowest {PLOTTED_MODES})")
    modes_parser.set_defaults(handler=_exit_statuses(modes))

    linearize_parser = commands.add_parser("linearize", help="the linear state-space model about a state: "
                                                             "JSON, .npz or MATLAB .mat")
    _point_options(linearize_parser)
    linearize_parser.add_argument("--input", action="append", default=[], metavar="PARAMETER",
                                  help="a parameter that acts as an input (gives a column of B); repeatable")
    linearize_parser.add_argument("--output", action="append", default=None, metavar="NAME", dest="outputs",
                                  help="an output (a row of C): a scene column, a declared output, a coordinate, "
                                       "energy or momentum(q); repeatable (default: the scene's columns)")
    linearize_parser.add_argument("-o", required=True, metavar="FILE", dest="file",
                                  help="where to write: lin.json, lin.npz or lin.mat")
    linearize_parser.set_defaults(handler=_exit_statuses(linearize))


def _point_options(parser) -> None:
    parser.usage_exit = BAD_INPUT_EXIT      # a usage error is bad input too
    parser.add_argument("model")
    common.scene_options(parser)
    parser.add_argument("--at", action="append", default=[], metavar="Q=VALUE",
                        help="the state: a coordinate as q=VALUE, its velocity as q.velocity=VALUE "
                             "(what is not given is the scene's start)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="override a parameter")
    parser.add_argument("--find", action="store_true",
                        help="find the equilibrium near the --at state first (Newton; velocities held)")


def _exit_statuses(handler):
    """Run `handler`; a LagError exits BAD_INPUT_EXIT, an AnalysisError NUMERICAL_FAILURE_EXIT."""
    @functools.wraps(handler)
    def run(arguments) -> int:
        try:
            return handler(arguments)
        except LagError as error:
            print(error.render(), file=sys.stderr)
            return BAD_INPUT_EXIT
        except AnalysisError as error:
            print(f"lagc: {error.render()}", file=sys.stderr)
            return NUMERICAL_FAILURE_EXIT
    return run


def _linear(arguments, inputs=(), outputs=None):
    """(model, linear model, the equilibrium found or None) of the command's point."""
    from ..linear import linearize_model
    model = common.load_model(SourceFile.read(arguments.model))
    at = dict(common.set_values(arguments.at, "--at"))
    linear, found = linearize_model(model, arguments.scene, at, dict(common.set_values(arguments.set)),
                                    inputs, outputs, arguments.find)
    return model, linear, found


def modes(arguments) -> int:
    """The table on stdout, the equilibrium found on stderr, -o CSV, --plot PNG. Without --plot the
    answer is kept for the next call with the same model text and options (run/answers.py)."""
    count = common.positive_integer("--count", arguments.count)     # bad input: exits 2 here, not 1 in parsing
    common.check_destinations(arguments.model, arguments.output, arguments.plot)
    if arguments.plot:
        answer = _modes_answer(arguments, count)
    else:
        options = [arguments.scene, arguments.at, arguments.set, arguments.find, bool(arguments.output)]
        answer = answers.kept("modes", SourceFile.read(arguments.model), options,
                              lambda: _modes_answer(arguments, count))
    print(answer["found"], end="", file=sys.stderr)
    print(answer["table"], end="")
    if arguments.output:
        write_output(arguments.output, answer["csv"])
    return 0


def _modes_answer(arguments, count: int) -> dict[str, str]:
    """The texts `lagc modes` prints and writes (the plot written here)."""
    from ..linear import analyse
    from ..linear.export import modes_csv, modes_text
    model, linear, found = _linear(arguments, outputs=())           # the modes need neither B nor C
    result = analyse(linear)
    title = f"{model.name} ({SourceFile.read(arguments.model).name})"
    if arguments.plot:
        from ..plots import mode_shapes_png
        write_output(arguments.plot, mode_shapes_png(result, f"mode shapes of {title}", count))
    return {"found": f"{found}\n" if found is not None else "", "table": modes_text(result, linear, title),
            "csv": modes_csv(result) if arguments.output else ""}


def linearize(arguments) -> int:
    from ..linear.export import check_format, write_linear
    check_format(arguments.file)
    check_writable(arguments.file, arguments.model)
    model, linear, found = _linear(arguments, tuple(arguments.input), arguments.outputs)
    if found is not None:
        print(found, file=sys.stderr)
    write_linear(arguments.file, linear, model.name, model.plan(arguments.scene).scene_name)
    print(f"wrote {len(linear.A)} states, {len(linear.inputs)} inputs, {len(linear.outputs)} outputs "
          f"to {arguments.file}", file=sys.stderr)
    return 0
