"""The commands that show a model rather than run it: `lagc check`, `lagc eom`, and `lagc cache`
for the build cache. A warm `lagc check` prints the answer stored by the first (run/answers.py)."""
from __future__ import annotations

import sys

from ..escape import visible
from ..run import answers, cache
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


def check(arguments) -> int:
    source = SourceFile.read(arguments.model)
    answer = answers.kept("check", source, [], lambda: _check_answer(source))
    print(answer["notes"], end="", file=sys.stderr)
    common.deliver(answer["summary"], None)
    return 0


def _check_answer(source: SourceFile) -> dict[str, str]:
    """What `lagc check` prints: the unit notes, the summary."""
    from ..present import describe_model
    model = common.load_model(source)
    notes = "".join(note.render() + "\n" for note in (model.ir.units.notes if model.ir.units else ()))
    return {"notes": notes, "summary": describe_model(model.ir, model.equations) + "\n"}


def eom(arguments) -> int:
    from ..present import format_equations
    model = common.load_model(SourceFile.read(arguments.model))
    common.deliver(format_equations(model.equations, latex=arguments.latex) + "\n", None)
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
