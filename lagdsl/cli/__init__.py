"""The `lagc` command: a thin layer over the Python API.

This is the only place that catches LagError: it prints `file:line:column: error: ...`
with the source line and a caret, and exits 1 (`lagc modes`, `lagc linearize` and `lagc lyapunov`
exit 2 for bad input and 1 for a numerical failure: cli/modes.py). Every message not about a place in a model
file begins `lagc: error:` (`lagc: warning:`, `lagc: interrupted`), usage errors included (exit 1,
as docs/language.md says). Anything else escaping is a bug in lagdsl.
Ctrl-C exits 130 (128 + SIGINT, as shells report it) without a traceback; during `lagc run`
the rows computed so far are written and the summary says where the run stopped.

`lagc run` first looks for the scene's stored plan (run/plans.py): a warm run imports neither
sympy nor lark, so the pipeline (api, present) is imported only by the commands that need it.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings

from .. import __version__
from ..errors import PREFIX, LagError, LagWarning, SimulationError
from ..escape import visible
from ..run.interrupt import terminate_as_interrupt
from . import animate, bench, common, describe, emit, fit, lyapunov, modes, simulate, sweep

COMMANDS = (describe, emit, simulate, animate, sweep, bench, modes, fit, lyapunov)    # each adds its subcommands to the parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    previous = signal.getsignal(signal.SIGTERM)
    try:
        terminate_as_interrupt()        # a `kill` keeps the rows computed so far, as Ctrl-C does
        with warnings.catch_warnings():
            warnings.simplefilter("default", LagWarning)
            warnings.showwarning = _show_warning
            return _dispatch(argv)
    except KeyboardInterrupt:
        print(f"{PREFIX}interrupted", file=sys.stderr)
        return common.interrupted_exit()
    except LagError as error:
        print(error.render(), file=sys.stderr)
        return 1
    except SimulationError as error:
        print(f"{PREFIX}error: {error.render()}", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # The reader went away (`lagc eom model.lag | head`): stop quietly, as Unix tools do.
        sys.stdout = open(os.devnull, "w")
        return 0
    except OSError as error:
        where = f": {visible(str(error.filename))}" if error.filename else ""
        print(f"{PREFIX}error: {error.strerror}{where}", file=sys.stderr)
        return 1
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"{PREFIX}warning: {message}", file=sys.stderr)


def _dispatch(argv: list[str]) -> int:
    parser, commands = _parser()
    if argv and argv[0] not in (*commands.choices, "-h", "--help", "--version") and "--emit" in argv:
        argv = ["emit", *argv]          # `lagc MODEL.lag --emit c` is `lagc emit MODEL.lag --emit c`
    arguments, unknown = parser.parse_known_args(argv)
    if unknown:     # said by the command's own parser: its usage line, its exit status
        commands.choices[arguments.command].error(f"unrecognized arguments: {' '.join(unknown)}")
    return arguments.handler(arguments)


class _Parser(argparse.ArgumentParser):
    """argparse with lagc's way of saying a usage error: the usage, then `lagc: error: ...`, exit
    status `usage_exit`: 1, as for every other bad option (argparse's own is `lagc run: error: ...`,
    exit 2); a command whose bad input exits otherwise sets it on its parser (cli/modes.py)."""

    usage_exit = 1

    def error(self, message: str):
        self.print_usage(sys.stderr)
        print(f"{PREFIX}error: {message}", file=sys.stderr)
        raise SystemExit(self.usage_exit)


def _parser() -> tuple[argparse.ArgumentParser, argparse._SubParsersAction]:
    parser = _Parser(
        prog="lagc", description="Compile Lagrangian models (.lag) to equations of motion, code and simulations.",
        epilog="Write `lagc MODEL.lag --emit c|numpy [-o FILE] [--scene S]` to emit source code, "
               "`lagc MODEL.lag --emit fmu -o Model.fmu [--fmi 2|3] [--kind cs|me|both]` for an FMU.")
    parser.add_argument("--version", action="version", version=f"lagc {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add(commands)
    return parser, commands
