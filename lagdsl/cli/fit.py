"""`lagc fit`: parameters fitted to measured data (least squares, the sensitivities as Jacobian)."""
from __future__ import annotations

import sys

from ..errors import LagError, Setting
from ..run.files import check_writable, write_output
from ..abi import parse_number
from ..settings import given_options
from ..source import SourceFile
from . import common


def add(commands) -> None:
    parser = commands.add_parser("fit", help="fit parameters to measured data (a CSV with t and output columns)")
    parser.add_argument("model")
    parser.add_argument("data", help="CSV: a header t,<outputs> (units as `t [s]` allowed), one row per time")
    common.scene_options(parser)
    common.integrator_options(parser)
    parser.add_argument("--fit", action="append", default=[], metavar="NAME=START", dest="fitted",
                        help="a parameter (or q.start, q.velocity) to fit, and its start value; repeatable")
    parser.add_argument("--bound", action="append", default=[], metavar="NAME=LOW:HIGH",
                        help="keep a fitted value in [LOW, HIGH]; repeatable")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="hold a parameter or start value at VALUE (a number in SI, or with a unit: '30 deg')")
    parser.add_argument("--output", action="append", default=None, metavar="COLUMN", dest="outputs",
                        help="a data column to fit (default: every column but t); repeatable")
    parser.add_argument("--sigma", type=float, help="the standard deviation of the data (default 1; the "
                                                    "standard errors are scaled by the residual variance)")
    parser.add_argument("--backend", choices=("c", "numpy"), default="numpy",
                        help="generated code that runs the model and its sensitivities (default: numpy)")
    parser.add_argument("-o", metavar="FIT.json", dest="file", help="write the fit as JSON")
    parser.add_argument("--plot", metavar="FIT.png", help="plot the data, the fitted model and the residuals")
    parser.set_defaults(handler=run)


def run(arguments) -> int:
    for path in (arguments.file, arguments.plot):
        if path is not None:
            check_writable(path, arguments.model)
    model = common.load_model(SourceFile.read(arguments.model))
    fitted = dict(common.set_values(arguments.fitted, "--fit"))
    if not fitted:
        raise LagError("name the parameters to fit: --fit NAME=START (repeatable)", Setting("--fit"))
    result = model.fit(arguments.data, fitted, outputs=arguments.outputs, sigma=arguments.sigma,
                       scene=arguments.scene, bounds=_bounds(arguments.bound),
                       set=dict(common.set_values(arguments.set, with_units=True)), integrator=arguments.integrator,
                       backend=arguments.backend, **dict(given_options(vars(arguments))), **_atol(arguments))
    print(result.render())
    if arguments.file is not None:
        write_output(arguments.file, result.to_json())
    if arguments.plot is not None:
        from ..plots import fit_png
        write_output(arguments.plot, fit_png(result))
    if not result.success:
        print(f"lagc: warning: the fit did not converge: {result.message}", file=sys.stderr)
    return 0


def _bounds(items: list[str]) -> dict[str, tuple[float, float]]:
    bounds = {}
    for item in items:
        name, _, text = item.partition("=")
        low, colon, high = text.partition(":")
        values = parse_number(low), parse_number(high)
        if not colon or None in values:
            raise LagError(f"--bound takes NAME=LOW:HIGH with numbers, got '{item}'", Setting("--bound"))
        bounds[name.strip()] = values
    return bounds


def _atol(arguments) -> dict:
    """--atol as given (numbers and NAME=VALUE pairs), which the plan splits (settings.split_atol)."""
    return {"atol": arguments.atol} if arguments.atol else {}
