"""`lagc animate`: run a scene with its draw statements and write the animation, a
self-contained HTML player, a GIF or an MP4; the run summary on stderr.

The output grid is one row per frame, an interval of speed/fps (unless --interval is given), so
the page holds the run's values at the times it shows. A run that fails or is interrupted still
writes the animation of the rows it computed, as `lagc run` writes them, and says where it stopped.
"""
from __future__ import annotations

import sys
from dataclasses import replace

from ..animation import DEFAULT_FPS, FORMATS, check_format, check_playback
from ..errors import SimulationError, SimulationInterrupted
from ..progress import TimeProgress
from ..run.files import check_writable
from ..source import SourceFile
from . import common


def add(commands) -> None:
    parser = common.run_command(commands, "animate", "run a scene and write its animation: an HTML player, a GIF "
                                                     "or an MP4 (from the model's draw statements)")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.html|FILE.gif|FILE.mp4",
                        help="where to write: " + "; ".join(f"{ending}: {meaning}" for ending, meaning in
                                                            FORMATS.items()))
    parser.add_argument("--fps", type=lambda text: common.positive_integer("--fps", text), default=DEFAULT_FPS,
                        help=f"frames per second of playback (default: {DEFAULT_FPS}); the output interval is "
                             "speed/fps unless --interval is given")
    parser.add_argument("--speed", type=float, default=1.0,
                        help="model seconds per second of playback (default: 1, real time)")
    parser.set_defaults(handler=animate)


def animate(arguments) -> int:
    check_playback(arguments.fps, arguments.speed, options=True)
    source = SourceFile.read(arguments.model)
    model = common.load_model(source)          # the model's errors first, as always
    check_format(arguments.output)
    check_writable(arguments.output, arguments.model)      # refuse before the run, not after it
    overrides = common.overrides(arguments)
    if overrides.interval is None:
        overrides = replace(overrides, interval=arguments.speed / arguments.fps)
    progress = TimeProgress()
    try:
        result = model.simulate_plan(arguments.scene, arguments.backend, overrides, progress, draw=True)
    except SimulationError as error:
        progress.close()
        if error.partial is not None and len(error.partial.t):
            error.partial.animate(arguments.speed).save(arguments.output, arguments.fps)
            print(error.partial.summary.render(), file=sys.stderr)
            print(f"the run is incomplete: it stopped at t = {error.time:.17g}; the animation of its "
                  f"{len(error.partial.t)} rows is in {arguments.output}", file=sys.stderr)
        if isinstance(error, SimulationInterrupted):
            print(f"lagc: {error.render()}", file=sys.stderr)
            return common.interrupted_exit()
        raise
    progress.close()
    result.animate(arguments.speed).save(arguments.output, arguments.fps)
    print(result.summary.render(), file=sys.stderr)
    return 0
