"""What the commands share: the options of a run, the overrides they give, loading a model and
delivering a text."""
from __future__ import annotations

import argparse
import signal

from ..abi import parse_number
from ..errors import LagError, Setting
from ..integrators import registry
from ..integrators.registry import OPTION_ORDER, OPTIONS
from ..run.files import check_writable, write_output, write_stdout
from ..progress import slow_stage
from ..run.interrupt import terminated
from ..settings import Overrides, check_integrator_name, given_options
from ..source import SourceFile


def interrupted_exit() -> int:
    """The exit status after an interrupt, as shells report a death by the signal: 128 + SIGINT
    (Ctrl-C) or 128 + SIGTERM (`kill`)."""
    return 128 + (signal.SIGTERM if terminated() else signal.SIGINT)


def check_destinations(model: str, output: str | None, plot: str | None) -> None:
    """Refuse before the work, not after it: a path that cannot be written, a plot without matplotlib."""
    for path in (output, plot):
        if path:
            check_writable(path, model)
    if plot:
        from .. import plots     # numpy and matplotlib: only a --plot needs them
        plots.require_matplotlib()


def load_model(source: SourceFile):
    """The model parsed and derived: the pipeline (sympy, lark) is imported only here."""
    from ..api import Model
    with slow_stage(f"parsing {source.name} and deriving its equations of motion"):
        return Model(source)


def run_options(parser: argparse.ArgumentParser) -> None:
    """What `lagc run` and `lagc sweep` take: the backend, the inputs and the integrator's options."""
    parser.add_argument("--backend", choices=("c", "numpy"), default="c", help="generated code to run (default: c)")
    input_options(parser)
    integrator_options(parser)


def integrator_options(parser: argparse.ArgumentParser) -> None:
    """--integrator and its options (--rtol, --atol, ...)."""
    methods = "; ".join(f"{record.name}: {record.description}" for record in map(registry.get, registry.names()))
    parser.add_argument("--integrator", metavar="NAME", help=f"the integration method ({methods})")
    for name in OPTION_ORDER:
        option = OPTIONS[name]
        users = ", ".join(record for record in registry.names() if name in registry.get(record).options)
        parser.add_argument("--" + option.flag, type=int if option.c_cast else float,
                            help=f"{option.meaning}: {option.requirement} ({users})")


def scene_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", help="scene to use (default: the model's first scene)")


def input_options(parser: argparse.ArgumentParser) -> None:
    """Parameters, initial values and the time grid: the inputs of a run."""
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter, or an initial value as COORDINATE.start / COORDINATE.velocity")
    parser.add_argument("--start", type=float, help="start time of the output grid")
    parser.add_argument("--stop", type=float, help="stop time")
    parser.add_argument("--interval", type=float, help="output interval")


def overrides(arguments) -> Overrides:
    options = given_options(vars(arguments))
    return Overrides(set_values(arguments.set), arguments.start, arguments.stop, arguments.interval,
                     arguments.integrator, options)


def set_values(items: list[str], option: str = "--set") -> tuple[tuple[str, float], ...]:
    """NAME=VALUE items of `option` (--set, or --at of `lagc modes`) as (name, number) pairs."""
    values = []
    for item in items:
        name, equals, text = item.partition("=")
        value = parse_number(text)
        if not equals or value is None:
            raise LagError(f"{option} takes NAME=VALUE with a number, got '{item}'")
        values.append((name.strip(), value))
    return tuple(values)


def refuse(option: str, message: str):
    raise LagError(message, Setting(option))


def positive_integer(option: str, text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    return value if value >= 1 else refuse(option, f"expected a whole number >= 1, got '{text}'")


def integrator_list(text: str | None) -> tuple[str, ...] | None:
    if text is None:
        return None
    names = tuple(name.strip() for name in text.split(",") if name.strip())
    for name in names:
        check_integrator_name(name, Setting("--integrators"))
    return names or refuse("--integrators", "expected a comma-separated list of integrators")


def deliver(text: str, output: str | None) -> None:
    """To the -o file (see `write_output`), or to standard output."""
    if output is not None:
        write_output(output, text)
    else:
        write_stdout(text)
