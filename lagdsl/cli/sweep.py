"""`lagc sweep`: many members of a scene (a grid or a random sample of inputs) in one call, one
tidy table to -o. On the C backend, with a stored plan of the scene (run/plans.py), a warm sweep
neither parses nor derives the model, as a warm `lagc run` does not."""
from __future__ import annotations

import contextlib
import math
import sys
from dataclasses import replace

import numpy as np

from ..errors import LagError, Setting, SimulationInterrupted
from ..run.files import check_writable
from ..settings import RUN_OPTIONS
from ..source import SourceFile
from . import common

RUN_KEYWORDS = ("start", "stop", "interval", "integrator", *RUN_OPTIONS)     # model.sweep's overrides


def add(commands) -> None:
    sweep_parser = common.run_command(commands, "sweep", "simulate many members (a grid or a random sample of "
                                                         "inputs); one tidy table to -o")
    sweep_parser.add_argument("--vary", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                       help="COUNT values from START to STOP; several --vary make the grid of all combinations")
    sweep_parser.add_argument("--random", action="append", default=[], metavar="NAME=LOW:HIGH",
                       help="uniform random values in [LOW, HIGH), -n of them (instead of --vary)")
    sweep_parser.add_argument("-n", type=int, dest="count", metavar="N", help="members of a --random sample")
    sweep_parser.add_argument("--seed", type=int, default=0, help="seed of the --random sample (default 0)")
    sweep_parser.add_argument("--workers", type=int, help="threads (default: OMP_NUM_THREADS, else every CPU); "
                       "with --dask local, worker processes")
    sweep_parser.add_argument("--dask", metavar="ADDRESS|local",
                       help="run on the Dask scheduler at ADDRESS, or on a local cluster of processes")
    sweep_parser.add_argument("-o", "--output", required=True,
                       help="the table: Parquet if the name ends in .parquet (needs pyarrow), else CSV")
    sweep_parser.set_defaults(handler=run)


def run(arguments) -> int:
    """Run the members of a grid or random sample; write the tidy table and the summary. Members
    that fail are rows with their status; Ctrl-C writes the members finished so far."""
    from ..run.sweep_job import stored_job, stream_to_file     # the runner: only the commands that run need it
    source = SourceFile.read(arguments.model)
    stored = _stored_plan(source, arguments)
    model = None if stored else common.load_model(source)
    check_writable(arguments.output, arguments.model)
    varied = sweep_values(arguments.vary, arguments.random, arguments.count, arguments.seed)
    overrides = common.overrides(arguments)
    varied = {**dict(overrides.values), **varied}
    job = stored and stored_job(stored, replace(overrides, values=()), varied)
    keywords = {k: getattr(arguments, k) for k in RUN_KEYWORDS if getattr(arguments, k) is not None}
    with _dask_client(arguments.dask, arguments.workers) as client:
        try:
            if job:
                summary = stream_to_file(job, arguments.output, arguments.workers, None, progress=True)
            else:
                model = model or common.load_model(source)
                summary = model.sweep_to_file(arguments.output, arguments.scene, arguments.backend, set=varied,
                                              workers=None if client else arguments.workers, client=client,
                                              progress=True, **keywords)
        except SimulationInterrupted as stopped:
            print(stopped.partial.render(), file=sys.stderr)
            print(f"lagc: interrupted; the table in {arguments.output} has the {stopped.partial.members} members "
                  "begun, those not finished with status 'interrupted'", file=sys.stderr)
            return common.interrupted_exit()
    print(summary.render(), file=sys.stderr)
    return 0


def _stored_plan(source: SourceFile, arguments):
    """The scene's stored plan (plans.StoredPlan) for a C sweep on this machine's threads (Dask
    and NumPy sweeps take the full pipeline)."""
    from ..run import plans
    if arguments.backend != "c" or arguments.dask is not None:
        return None
    return plans.find(source, arguments.scene, arguments.backend, arguments.integrator)


@contextlib.contextmanager
def _dask_client(address: str | None, workers: int | None):
    """A dask.distributed Client for --dask (None without it): `local` starts a LocalCluster of
    worker processes here, any other value is a scheduler's address."""
    if address is None:
        yield None
        return
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise LagError("--dask needs dask.distributed: pip install 'lagdsl[sweep]'", Setting("--dask")) from None
    if address == "local":
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            yield client
        return
    try:
        client = Client(address, timeout="10s")
    except (OSError, ValueError, TypeError) as error:
        raise LagError(f"cannot reach the Dask scheduler at '{address}': {error}", Setting("--dask")) from None
    with client:
        yield client


def sweep_values(vary: list[str], sample: list[str], count: int | None, seed: int) -> dict[str, np.ndarray]:
    """The members of `lagc sweep`: the grid of all combinations of the --vary ranges (the last
    varying fastest), or -n uniform random draws in each --random range, from `seed`."""
    if vary and sample:
        raise LagError("give either --vary (a grid) or --random (a sample), not both", Setting("--random"))
    if sample and count is None:
        raise LagError("needs -n, the number of members", Setting("--random"))
    if count is not None and not sample:
        raise LagError("-n is the size of a --random sample; a --vary grid has the size of its ranges", Setting("-n"))
    if count is not None and count < 1:
        raise LagError(f"the sample needs at least one member, not {count}", Setting("-n"))
    if not vary and not sample:
        raise LagError("nothing varies: give --vary NAME=START:STOP:COUNT or --random NAME=LOW:HIGH with -n N")
    option = "--vary" if vary else "--random"
    ranges = [_range(option, item, 3 if vary else 2) for item in vary or sample]
    names = [name for name, _ in ranges]
    for name in names:
        if names.count(name) > 1:
            raise LagError(f"'{name}' is varied twice", Setting(option))
    if sample:
        rng = np.random.default_rng(seed)
        return {name: rng.uniform(low, high, count) for name, (low, high) in ranges}
    axes = [np.linspace(start, stop, int(points)) for _, (start, stop, points) in ranges]
    grid = np.meshgrid(*axes, indexing="ij")
    return {name: axis.reshape(-1) for name, axis in zip(names, grid)}


def _range(option: str, item: str, fields: int) -> tuple[str, tuple[float, ...]]:
    form = "NAME=START:STOP:COUNT" if fields == 3 else "NAME=LOW:HIGH"
    name, equals, text = item.partition("=")
    parts = text.split(":")
    try:
        numbers = tuple(float(part) for part in parts)
    except ValueError:
        numbers = ()
    if not equals or not name.strip() or len(numbers) != fields or not all(map(math.isfinite, numbers)):
        raise LagError(f"expected {form} with finite numbers, got '{item}'", Setting(f"{option} {item}"))
    if fields == 3 and not (numbers[2] >= 1 and numbers[2] == int(numbers[2])):
        raise LagError(f"COUNT must be a whole number >= 1, got '{parts[2]}'", Setting(f"{option} {item}"))
    if fields == 2 and not numbers[0] < numbers[1]:
        raise LagError(f"need LOW < HIGH, got '{text}'", Setting(f"{option} {item}"))
    return name.strip(), numbers
