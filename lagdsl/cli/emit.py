"""`lagc MODEL --emit c|numpy|fmu`: the generated source of a scene, or the scene as an FMU
(lagdsl/fmu.py: FMI 2.0 or 3.0, for model exchange, co-simulation or both)."""
from __future__ import annotations

from ..errors import LagError, Setting
from ..run.files import check_writable
from ..source import SourceFile
from . import common

LANGUAGES = ("c", "numpy", "fmu")
FMU_KINDS = {"cs": ("cs",), "me": ("me",), "both": ("me", "cs")}


def add(commands) -> None:
    parser = commands.add_parser("emit", help="write the generated source, or an FMU: "
                                              "lagc MODEL --emit c|numpy|fmu [-o FILE]")
    parser.add_argument("model")
    parser.add_argument("--emit", required=True, choices=LANGUAGES, dest="language")
    common.scene_options(parser)
    parser.add_argument("-o", "--output", help="file to write (default: standard output; an FMU needs one)")
    parser.add_argument("--fmi", type=int, help="with --emit fmu: the FMI version "
                                                                           "(default: 2, FMI 2.0)")
    parser.add_argument("--kind", choices=tuple(FMU_KINDS),
                        help="with --emit fmu: co-simulation (cs), model exchange (me) or both (default; cs for a scene "
                             "integrated in Hamilton's form)")
    parser.set_defaults(handler=emit)


def emit(arguments) -> int:
    _check_fmu_options(arguments)
    if arguments.output is not None:
        check_writable(arguments.output, arguments.model)
    model = common.load_model(SourceFile.read(arguments.model))
    if arguments.language == "fmu":
        from ..fmu import build_fmu
        common.deliver(build_fmu(model, arguments.scene, arguments.fmi or 2, FMU_KINDS.get(arguments.kind)), arguments.output)
    else:
        common.deliver(model.emit(arguments.language, arguments.scene).text, arguments.output)
    return 0


def _check_fmu_options(arguments) -> None:
    """An FMU is written to a file; --fmi and --kind are an FMU's."""
    if arguments.language == "fmu" and arguments.output is None:
        raise LagError("an FMU is a zip archive: name the file to write with -o, as in -o Model.fmu", Setting("-o"))
    for option in ("fmi", "kind"):
        if arguments.language != "fmu" and getattr(arguments, option) is not None:
            raise LagError("an option of --emit fmu only", Setting("--" + option))
