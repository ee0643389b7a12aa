"""What the commands share: the options of a run, the overrides they give, loading a model and
delivering a text."""
from __future__ import annotations

import argparse
import signal

from ..abi import parse_number
from ..errors import InputError, LagError, Setting
from ..integrators import registry
from ..integrators.registry import OPTION_ORDER, OPTIONS
from ..run.files import check_writable, write_output, write_stdout
from ..progress import slow_stage
from ..run.interrupt import terminated
from ..settings import Overrides, check_integrator_name, given_atol_each, given_options
from ..tolerances import component_key
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


def run_command(commands, name: str, help: str) -> argparse.ArgumentParser:
    """The parser of a command that runs a scene of a model (run, sweep, animate): the model, the
    scene and the run's options."""
    parser = commands.add_parser(name, help=help)
    parser.add_argument("model")
    scene_options(parser)
    run_options(parser)
    return parser


def run_options(parser: argparse.ArgumentParser) -> None:
    """What `lagc run`, `lagc sweep` and `lagc animate` take: the backend, the inputs and the
    integrator's options."""
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
        if name == "atol":
            parser.add_argument("--atol", action="append", type=atol_item, metavar="[COMPONENT=]VALUE",
                                help=f"{option.meaning}: {option.requirement}, for every component of the state, "
                                     "or for one as x=1e-18 or der(x)=1e-6 (a coordinate or its velocity, in its declared unit "
                                     "like --set, or with a unit: 'x=1e-15 mm'; "
                                     f"repeat the option for more) ({users})")
            continue
        kind = str if option.choices else int if option.c_cast else (lambda text, flag=option.flag: time_value(f"--{flag}", text)) \
            if option.time else float
        seconds = " in seconds, or a number and a unit of time ('1 ms')" if option.time else ""
        parser.add_argument("--" + option.flag, type=kind, choices=option.choices or None,
                            help=f"{option.meaning}: {option.requirement}{seconds} ({users})")


def atol_item(text: str) -> float | tuple[str, float | str]:
    """--atol VALUE, or --atol COMPONENT=VALUE (tolerances.py), whose VALUE is a number in the
    component's declared unit or a text of a number and a unit (given_values.input_in_si reads it)."""
    name, equals, number = text.rpartition("=")
    value = parse_number(number.strip())
    if (value is None and not (equals and number.strip())) or (equals and not name.strip()):
        raise LagError(f"--atol takes a number, or COMPONENT=NUMBER such as x=1e-18 or der(x)=1e-6, got '{text}'",
                       Setting("--atol"))
    return (component_key(name), number.strip() if value is None else value) if equals else value


def scene_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", help="scene to use (default: the model's first scene)")


def input_options(parser: argparse.ArgumentParser) -> None:
    """Parameters, initial values and the time grid: the inputs of a run."""
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter, or an initial value as COORDINATE.start / COORDINATE.velocity; "
                             "a plain number is in the unit the model declares for it (as in the model file), "
                             "a number with a unit ('30 deg', '500g') is converted")
    for option, meaning in (("start", "start time of the output grid"), ("stop", "stop time"),
                            ("interval", "output interval")):
        parser.add_argument(f"--{option}", type=lambda text, option=option: time_value(f"--{option}", text),
                            help=f"{meaning}: seconds, or a number and a unit of time ('0.8 ns', '2 min')")


def overrides(arguments) -> Overrides:
    options = given_options(vars(arguments))
    return Overrides(set_values(arguments.set, with_units=True), arguments.start, arguments.stop, arguments.interval,
                     arguments.integrator, options, given_atol_each(vars(arguments)))


def set_values(items: list[str], option: str = "--set",
               with_units: bool = False) -> tuple[tuple[str, float | str], ...]:
    """NAME=VALUE items of `option` (--set, or --at of `lagc modes`) as (name, number) pairs; with
    `with_units`, a VALUE that is a number and a unit (`theta.start=30 deg`) is kept as its text,
    which the plan converts to SI (scene.plan_scene)."""
    values = []
    for item in items:
        name, equals, text = item.partition("=")
        value = parse_number(text)
        if with_units and equals and value is None and text.strip():
            value = text.strip()
        if not equals or value is None:
            raise LagError(f"{option} takes NAME=VALUE with a number{' (and a unit)' if with_units else ''}, "
                           f"got '{item}'")
        values.append((name.strip(), value))
    return tuple(values)


def time_value(option: str, text: str) -> float:
    value = parse_number(text.strip())
    if value is not None:
        return value
    from ..frontend.units import time_in_seconds     # with sympy, which a warm run does without
    try:
        return time_in_seconds(text.strip(), option)
    except InputError as error:     # a ValueError, which argparse would take for its own "invalid value"
        raise LagError.combine([error]) from None


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
