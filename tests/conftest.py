"""Shared fixtures and helpers: model paths, loading, the --update-golden and --slow options, a
build cache of the test suite's own, and `lagc` run in this process.

The default run leaves out the tests marked `slow` (the exhaustive matrices: every model with
every integrator on both backends, every scene compiled strictly four ways, the fuzz slice, Dask,
the test set); `--slow` runs them too, `-m slow` only them, and a test named by its node id
(`tests/x.py::test_y`) runs whatever its marker.

What the default run keeps of each kind (issue 28), and where; a matrix's other cases are slow:
- mass-matrix layout, strict compile: dense Cholesky pendulum_chain.swing, sparse saddle point of
  many constraints cartesian_chain.swing, local form with the banded Jacobian fpu_chain.implicit
  (codegen/test_strict_compile.py's DEFAULT_SCENES); dense small and constant M in the goldens
  (codegen/test_golden.py compiles and runs eight C goldens strictly, among them double_pendulum.chaos
  and fem_string.mode2; fpu_chain.spread and fem_string_fine.mode2 are compared as text only). Closed form: mechanics/test_textbook_systems.py
  (test_pendulum_chain_mass_matrix, test_double_pendulum_matches_the_worksheet_not_the_notes).
- constraint kind, strict compile: holonomic wedge.slide, nonholonomic rolling_penny.roll, a stop on
  a multiplier ladder.slide (goldens), rheonomic car_axis.bumps (test_strict_compile.py) and
  codegen/test_kernel_names.py's [rheonomic-radau5]. Closed form: holonomic
  test_cartesian_pendulum_multiplier_is_the_rod_force and test_wedge_accelerations, nonholonomic
  models/test_constrained.py::test_rolling_penny_follows_the_corrected_closed_form, rheonomic
  mechanics/test_textbook_systems.py::test_bead_on_a_turning_rod_is_flung_out_and_pushed_by_the_coriolis_force, unilateral
  run/test_stop_condition.py::test_the_ladder_leaves_the_wall_where_its_multiplier_turns_negative.
- Jacobian kind, strict compile: dense (kernel_names [everything-radau5]), banded
  (fpu_chain.implicit), augmented with constraints (sensitivity/test_c_sensitivities.py's
  [cartesian_pendulum-radau5]). Agreement with an independent solution:
  run/test_all_models.py [double_pendulum-radau5-c], run/test_backends.py (C radau5 against scipy's Radau).
- integrator family, strict compile: explicit RK (goldens wedge, rolling_penny), rkn8 (pleiades.nystrom),
  gauss (kepler.symplectic), radau5 (fpu_chain.implicit), taylor (run/test_taylor.py).
  Closed form: run/test_stop_condition.py::test_the_flight_ends_where_it_comes_down (every
  integrator but auto, whose two methods it runs, on both backends) and, for the Taylor method,
  run/test_si_scales.py's cyclotron [c-taylor] and the ladder [c-taylor].

`--cpu-report N` lists the N tests that took most CPU, the C compilers they started included: the
figure to watch when a test joins the default run. A test that runs a model of its own text in C
writes it with `model_file` rather than to tmp_path: the generated C names the model's path, so a
new path is a new build in every run; a test that needs a build cache of its own (cold, counted or
damaged) takes it from `own_cache`, which builds at -O0. A test that runs the C compiler itself
calls `compiled`, which replays a compile that succeeded before on the same bytes; a property
test draws `examples(n)` examples (all n with --slow). The suite writes Python's bytecode even
under PYTHONDONTWRITEBYTECODE (_write_bytecode).
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import io
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
_OWN_CACHE: list[str] = []       # the build cache this process made for the session, removed at its end
_MODEL_FILES: list[Path] = []    # where model_file writes, set when the session is configured
_COMPILED: list[Path] = []       # where compiled() keeps what the compiler made, set likewise
_WHOLE_SUITE: list[bool] = []    # whether this session runs the slow tests too, set likewise


def without_units(text: str) -> str:
    """A model's text with its unit annotations removed: a model without units is not checked
    dimensionally (for tests that change a model in ways its units would not allow)."""
    return re.sub(r"(?<=[ \t])\[[^\]\n]*\]", "", text)


@functools.cache
def library_model(name: str):
    """The library model `models/<name>.lag`, loaded (parsed and derived) once per session.

    Shared by every test that only plans, emits or simulates it: a Model keeps the code it has
    built, so a test that counts builds or needs a cold model calls lagdsl.load itself."""
    import lagdsl
    return lagdsl.load(MODELS / f"{name}.lag")


@functools.cache
def library_scenes() -> tuple[tuple[str, str | None], ...]:
    """(model, scene) for every scene of every library model (None for a model without scenes),
    read from the parse trees alone (a scene is `scene NAME ... end NAME;`): collection neither
    derives nor checks a model, which costs a few seconds in every xdist worker. The list is kept
    beside model_file's models under the hash of the models, the grammar and the parser: parsing
    the library costs each worker about a second of its collection."""
    paths = sorted(MODELS.glob("*.lag"))
    digest = hashlib.sha256()
    for path in [ROOT / "lagdsl" / "frontend" / "grammar.lark", ROOT / "lagdsl" / "frontend" / "parser.py", *paths]:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    kept = _MODEL_FILES[0] / f"library-scenes-{digest.hexdigest()[:24]}.json"
    if kept.exists():
        return tuple((model, scene) for model, scene in json.loads(kept.read_text(encoding="utf-8")))
    from lagdsl.frontend.parser import parse
    from lagdsl.source import SourceFile
    scenes = tuple((path.stem, scene) for path in paths
                   for scene in (tuple(str(node.children[1]) for node in parse(SourceFile.read(path)).find_data("scene"))
                                 or (None,)))
    partial = kept.with_name(f"{kept.name}.{os.getpid()}.part")     # workers may write it at once
    partial.write_text(json.dumps(scenes), encoding="utf-8")
    os.replace(partial, kept)
    return scenes


def examples(full: int) -> int:
    """How many examples a property test draws: `full` when the slow tests run too (--slow, -m), a
    fifth of it (at least 5) in the default run, where the @example cases still all run."""
    return full if not _WHOLE_SUITE or _WHOLE_SUITE[0] else max(full // 5, 5)


def slow_unless_kept(cases, kept) -> list:
    """`cases` for pytest.mark.parametrize, those not in `kept` marked slow: the default run keeps
    the representatives of a matrix, --slow runs all of it."""
    return [case if case in kept else pytest.param(*(case if isinstance(case, tuple) else (case,)),
                                                   marks=pytest.mark.slow)
            for case in cases]


def own_cache(monkeypatch, path: Path) -> Path:
    """`path` as the build cache from now on (this process and those it starts), for a test that
    needs a cache of its own (cold, counted or damaged), its libraries built at -O0: such a test
    builds each one anew and runs it for milliseconds, gcc takes a third of its -O3 time, and the
    level changes no result (run/toolchain.py); the suite's own cache keeps the shipped flags."""
    monkeypatch.setenv("LAGDSL_CACHE", str(path))
    monkeypatch.setenv("LAGDSL_OPTIMIZE", "0")
    return path


def model_file(text: str, name: str = "model") -> Path:
    """`text` written to `NAME.lag` in a directory of the suite's own named by the text's hash: the
    same path in every test, worker and run. The generated C names the path of its model, so a model
    written to tmp_path is compiled afresh in each test; one written here is built once and found
    in the build cache from then on. The file is shared: a test that edits its model, or writes
    beside it, uses tmp_path. A `name` with slashes puts the model in directories of those names
    (a test of hostile paths)."""
    path = _MODEL_FILES[0] / hashlib.sha256(f"{name}\0{text}".encode()).hexdigest()[:24] / f"{name}.lag"
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f"{path.name}.{os.getpid()}.part")     # workers may write it at once
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, path)
    return path


def compiled(command: list, check: bool = False) -> subprocess.CompletedProcess:
    """The C compiler's `command` run as subprocess.run runs it (output and errors captured as text),
    or its success replayed: the same compiler given the same flags and the same bytes in its
    files (and in the directories that -I names) makes the same output and the same warnings, so
    a compile that succeeded once is looked up by that content, its output (`-o`) copied out, as
    ccache would. A strict compile still fails on a warning whenever the code changes; a compile
    that failed is never kept. The store lives beside the build cache (pytest --cache-clear empties it)."""
    command = [str(argument) for argument in command]
    output = command[command.index("-o") + 1] if "-o" in command else None
    key = _compile_key(command, output)
    kept = _COMPILED[0] / key
    if kept.exists() and (output is None or (kept / "output").exists()):
        if output is not None:
            shutil.copy2(kept / "output", output)
        return subprocess.CompletedProcess(command, 0, "", (kept / "stderr").read_text(encoding="utf-8"))
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode == 0:
        partial = _COMPILED[0] / f".{key}.{os.getpid()}.{threading.get_ident()}"
        partial.mkdir(parents=True, exist_ok=True)
        (partial / "stderr").write_text(done.stderr, encoding="utf-8")
        if output is not None:
            shutil.copy2(output, partial / "output")
        with contextlib.suppress(OSError):      # another worker kept the same compile first
            os.rename(partial, kept)
        shutil.rmtree(partial, ignore_errors=True)
    elif check:
        raise subprocess.CalledProcessError(done.returncode, command, done.stdout, done.stderr)
    return done


def _compile_key(command: list[str], output: str | None) -> str:
    """The SHA-256 of what a compile depends on: the compiler itself, each argument, a file's bytes
    in place of its path, and every file of a directory that -I names (the output's path aside)."""
    digest = hashlib.sha256(_compiler_identity(command[0]).encode())
    for previous, argument in zip([None, *command], command):
        path = Path(argument)
        if previous == "-o":
            digest.update(b"\0-o")
        elif previous == "-I" and path.is_dir():
            for member in sorted(path.iterdir()):
                if member.is_file():
                    digest.update(b"\0" + member.name.encode() + b"\0" + member.read_bytes())
        elif path.is_file():
            digest.update(b"\0file\0" + path.read_bytes())
        else:
            digest.update(b"\0" + argument.encode())
    return digest.hexdigest()[:32]


@functools.cache
def _compiler_identity(compiler: str) -> str:
    """The compiler's path, modification time and version: a new compiler is a new key."""
    path = Path(shutil.which(compiler) or compiler).resolve()
    version = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout
    return f"{path}\0{path.stat().st_mtime_ns}\0{version}"


@dataclass(frozen=True)
class Ran:
    """What `lagc` gave: its exit code and its two streams (as subprocess.CompletedProcess names them)."""
    returncode: int
    stdout: str
    stderr: str


def lagc_in_process(*arguments) -> Ran:
    """`lagc ARGUMENTS` run by this interpreter, with the exit code the console script would give:
    no new interpreter to start, and lagdsl's caches are warm. An exception escaping `main` is
    printed as a traceback on stderr and exits 1, as Python does for the script."""
    from lagdsl.cli import main
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            code = main([str(argument) for argument in arguments])
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else int(exit_.code is not None)
        except Exception:       # noqa: BLE001 - reported as the script would report it
            traceback.print_exc()
            code = 1
    return Ran(code, stdout.getvalue(), stderr.getvalue())


def pytest_addoption(parser):
    parser.addoption("--update-golden", action="store_true", default=False,
                     help="rewrite tests/golden/ from the current code generator, and the stored reference "
                          "trajectories (tests/mechanics/references/) by solving them again")
    parser.addoption("--slow", action="store_true", default=False,
                     help="run the tests marked slow too (the whole suite)")
    parser.addoption("--cpu-report", type=int, default=None, metavar="N",
                     help="report the N tests that took most CPU (this process and the compilers "
                          "it started), and the total over all tests")


def pytest_configure(config):
    """SIGINT gets Python's own handler (see python_handles_ctrl_c); then:

    Builds go to a cache of the test suite's own, never to the user's ~/.cache/lagdsl, unless
    LAGDSL_CACHE names one (.ci/run does, to keep builds between its steps). The suite's cache
    lives in pytest's cache directory (.pytest_cache/d/lagdsl-builds), so a developer's next run
    starts warm, as ccache would, and `pytest --cache-clear` empties it; without pytest's cache
    (`-p no:cacheprovider`) it is a temporary directory removed at the session's end. xdist's
    workers inherit it from the controller, so they share it (the cache takes concurrent builds);
    a test that needs a cold cache makes its own. The models that model_file writes live beside it
    (.pytest_cache/d/lagdsl-models), or in a temporary directory without pytest's cache."""
    _handle_ctrl_c_as_python_does()
    _write_bytecode()
    _WHOLE_SUITE[:] = [bool(config.getoption("--slow") or config.getoption("markexpr"))]
    _MODEL_FILES[:] = [_suite_directory(config, "lagdsl-models")]
    _COMPILED[:] = [_suite_directory(config, "lagdsl-compiled")]
    if os.environ.get("LAGDSL_CACHE"):
        return
    if getattr(config, "cache", None) is not None and not hasattr(config, "workerinput"):
        os.environ["LAGDSL_CACHE"] = str(config.cache.mkdir("lagdsl-builds"))
        return
    os.environ["LAGDSL_CACHE"] = _own_temporary_directory("lagdsl-test-cache-")


def _write_bytecode() -> None:
    """Python's bytecode written beside the sources (gitignored __pycache__), for this process and the
    ones it starts, even where PYTHONDONTWRITEBYTECODE asks otherwise: without it each xdist worker
    rewrites the tests' asserts again (about 4 s of CPU) and each `lagc` subprocess compiles lagdsl
    again (0.3 s), a cost no installed lagdsl pays (benchmarks/small_commands.py lets its commands
    keep bytecode likewise). The installed packages have theirs already."""
    sys.dont_write_bytecode = False
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)


def _suite_directory(config, name: str) -> Path:
    """A directory of pytest's cache (kept between runs), or a temporary one without pytest's cache."""
    if getattr(config, "cache", None) is not None:
        return Path(config.cache.mkdir(name))
    return Path(_own_temporary_directory(f"{name}-"))


def _own_temporary_directory(prefix: str) -> str:
    """A temporary directory removed at the session's end."""
    path = tempfile.mkdtemp(prefix=prefix)
    _OWN_CACHE.append(path)
    return path


def pytest_unconfigure(config):
    for path in _OWN_CACHE:
        shutil.rmtree(path, ignore_errors=True)
        if os.environ.get("LAGDSL_CACHE") == path:
            del os.environ["LAGDSL_CACHE"]
    _OWN_CACHE.clear()
    _MODEL_FILES.clear()
    _COMPILED.clear()


def pytest_collection_modifyitems(config, items):
    """Leave the slow tests out, unless --slow, a marker expression (-m) or a node id asks for them."""
    if config.getoption("--slow") or config.getoption("markexpr"):
        return
    named = [_node_id(config, argument) for argument in config.args if "::" in argument]
    kept, left_out = [], []
    for item in items:
        asked = any(item.nodeid == name or item.nodeid.startswith((f"{name}[", f"{name}::")) for name in named)
        (kept if asked or item.get_closest_marker("slow") is None else left_out).append(item)
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        items[:] = kept


def _node_id(config, argument: str) -> str:
    """A command-line node id (`tests/x.py::test_y`, from any directory) as pytest's items spell it."""
    path, rest = argument.split("::", 1)
    relative = (config.invocation_params.dir / path).resolve().relative_to(config.rootpath)
    return f"{relative.as_posix()}::{rest}"


def _handle_ctrl_c_as_python_does() -> None:
    """Python's own SIGINT handler in this process, where it started with SIGINT ignored.

    A shell without job control starts a background command (`.ci/run &`, `nohup pytest &`) with
    SIGINT ignored, and Python then installs no handler of its own; xdist's workers inherit that.
    lagdsl rightly leaves an ignored SIGINT alone (no Ctrl-C reaches a background job), so the
    Ctrl-C tests, which send SIGINT to their own process, would see their press ignored and run
    on: a CI run once hung for that in test_ctrl_c_stops_a_run_and_keeps_its_rows[numpy]."""
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def python_handles_ctrl_c():
    """Each test starts with Python's own SIGINT handler, which the runs' Ctrl-C handling builds on.

    Any other handler found (one that a test left behind) is put back to Python's and named in a
    warning, so that the suite reports the leak instead of losing a later test's Ctrl-C to it."""
    if threading.current_thread() is threading.main_thread():
        found = signal.getsignal(signal.SIGINT)
        if found is not signal.default_int_handler:
            signal.signal(signal.SIGINT, signal.default_int_handler)
            warnings.warn(f"SIGINT was handled by {found!r} when this test started; Python's handler put back")
    yield


@pytest.fixture
def update_golden(request) -> bool:
    return request.config.getoption("--update-golden")


def _cpu_seconds() -> tuple[float, float]:
    """CPU time of this process, and of its finished children (the C compiler, a new interpreter)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


_CPU_MARK: list[tuple[float, float]] = []     # the CPU times when the phase now running began, with --cpu-report
_CPU_BY_TEST: dict[str, tuple[float, float]] = {}     # node id -> (CPU in the test's process, in its children)


def pytest_runtest_logstart(nodeid, location):
    _CPU_MARK[:] = [_cpu_seconds()]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """With --cpu-report, each phase's report carries its CPU seconds in its user properties
    (which reach xdist's controller with the report)."""
    outcome = yield
    if item.config.getoption("--cpu-report") is None or not _CPU_MARK:
        return
    now = _cpu_seconds()
    outcome.get_result().user_properties.append(("cpu_seconds", tuple(b - a for a, b in zip(_CPU_MARK[0], now))))
    _CPU_MARK[:] = [now]


def pytest_runtest_logreport(report):
    for key, value in getattr(report, "user_properties", ()):
        if key == "cpu_seconds":
            own, children = _CPU_BY_TEST.get(report.nodeid, (0.0, 0.0))
            _CPU_BY_TEST[report.nodeid] = (own + value[0], children + value[1])


def pytest_terminal_summary(terminalreporter, config):
    """The --cpu-report: the total, the share of child processes (compilers, new interpreters),
    each test file's sum, then the costliest tests."""
    count = config.getoption("--cpu-report")
    if count is None or not _CPU_BY_TEST:
        return
    ranked = sorted(_CPU_BY_TEST.items(), key=lambda entry: -sum(entry[1]))
    by_file: dict[str, tuple[float, float]] = {}
    for nodeid, (own, children) in ranked:
        name = nodeid.split("::")[0]
        by_file[name] = (by_file.get(name, (0.0, 0.0))[0] + own, by_file.get(name, (0.0, 0.0))[1] + children)
    total = sum(own + children for own, children in _CPU_BY_TEST.values())
    in_children = sum(children for _, children in _CPU_BY_TEST.values())
    terminalreporter.section(f"CPU seconds: {total:.1f} over {len(ranked)} tests (collection aside), "
                             f"{in_children:.1f} of them in child processes (compilers, interpreters)")
    terminalreporter.write_line("   total  children  file")
    for name, (own, children) in sorted(by_file.items(), key=lambda entry: -sum(entry[1]))[:count]:
        terminalreporter.write_line(f"{own + children:8.2f}  {children:8.2f}  {name}")
    terminalreporter.write_line("   total  children  test")
    for nodeid, (own, children) in ranked[:count]:
        terminalreporter.write_line(f"{own + children:8.2f}  {children:8.2f}  {nodeid}")
