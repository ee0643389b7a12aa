"""The commands that show a model rather than run it: `lagc check`, `lagc eom`, `lagc MODEL
--emit c|numpy`, and `lagc cache` for the build cache."""
from __future__ import annotations

import sys

from ..escape import visible
from ..run import cache
from ..run.files import check_writable
from ..source import SourceFile
from . import common


def add(commands) -> None:
    check_parser = commands.add_parser("check", help="validate a model; print degrees of freedom, constraints, conserved quantities, scenes")
    check_parser.add_argument("model")
    check_parser.set_defaults(handler=check)

    eom_parser = commands.add_parser("eom", help="print the derived equations of motion")
    eom_parser.add_argument("model")
    eom_parser.add_argument("--latex", action="store_true", help="print LaTeX (an aligned environment)")
    eom_parser.set_defaults(handler=eom)

    cache_command_parser = commands.add_parser("cache", help="show where the build cache is and its size, or empty it")
    cache_command_parser.add_argument("action", choices=("info", "clear"))
    cache_command_parser.set_defaults(handler=cache_command)

    emit_parser = commands.add_parser("emit", help="write the generated source: lagc MODEL --emit c|numpy [-o FILE]")
    emit_parser.add_argument("model")
    emit_parser.add_argument("--emit", required=True, choices=("c", "numpy"), dest="language")
    common.scene_options(emit_parser)
    emit_parser.add_argument("-o", "--output", help="file to write (default: standard output)")
    emit_parser.set_defaults(handler=emit)


def emit(arguments) -> int:
    if arguments.output is not None:
        check_writable(arguments.output, arguments.model)
    model = common.load_model(SourceFile.read(arguments.model))
    common.deliver(model.emit(arguments.language, arguments.scene).text, arguments.output)
    return 0


def check(arguments) -> int:
    from ..present import describe_model
    model = common.load_model(SourceFile.read(arguments.model))
    for note in model.ir.units.notes if model.ir.units else ():
        print(note.render(), file=sys.stderr)
    common.deliver(describe_model(model.ir, model.equations) + "\n", None)
    return 0


def eom(arguments) -> int:
    from ..mechanics.families import expanded
    from ..present import format_equations
    model = common.load_model(SourceFile.read(arguments.model))
    common.deliver(format_equations(expanded(model.equations), latex=arguments.latex) + "\n", None)
    return 0


def cache_command(arguments) -> int:
    """`lagc cache info`: where the cache is, how many entries and bytes; `lagc cache clear`: empty it."""
    where = visible(cache.cache_root())
    if arguments.action == "clear":
        common.deliver(f"removed {cache.clear()} entries from the build cache {where}\n", None)
    else:
        entries, size = cache.usage()
        common.deliver(f"build cache {where}: {entries} entries, {size / 1e6:.1f} MB\n", None)
    return 0
