"""The `lagc` command: a thin layer over the Python API.

This is the only place that catches LagError: it prints `file:line:column: error: ...`
with the source line and a caret, and exits 1. Anything else escaping is a bug in lagdsl.
"""
from __future__ import annotations

import argparse
import sys

from . import __version__
from .errors import LagError, SimulationError
from .pipeline import load_equations


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        return _dispatch(argv)
    except LagError as error:
        print(error.render(), file=sys.stderr)
        return 1
    except SimulationError as error:
        print(error.render(), file=sys.stderr)
        return 1
    except OSError as error:
        print(f"lagc: error: {error.strerror}: {error.filename}", file=sys.stderr)
        return 1


def _dispatch(argv: list[str]) -> int:
    parser = _parser()
    if argv and argv[0] not in ("check", "eom", "run", "-h", "--help", "--version") and "--emit" in argv:
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
    return parser


def _check(arguments) -> int:
    from .present import describe_model
    model, equations = load_equations(arguments.model)
    print(describe_model(model, equations))
    return 0


def _eom(arguments) -> int:
    from .present import format_equations
    _, equations = load_equations(arguments.model)
    print(format_equations(equations, latex=arguments.latex))
    return 0


if __name__ == "__main__":
    sys.exit(main())
