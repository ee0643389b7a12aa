"""Forward sensitivities on the C backend: the augmented system integrated by the scene's own C
integrator (codegen/c_sensitivity.py, templates/c/sensitivity.c.j2), called through ctypes.

The start (S(0), its projection onto the constraints), the output columns and their derivatives
on the grid are those of the NumPy path (run.py, variational.py), from the same kernel: only the
integration differs. The C program orders the augmented state as a second-order system,
Y = (q, Sq_1 .. Sq_m, q', Sv_1 .. Sv_m), so that rkn8 and radau5 see the structure they use;
`augmented` and `first_order` convert from and to run.py's (y, S by rows).
"""
from __future__ import annotations

import ctypes
import time as clock

import numpy as np

from ..abi import SETTINGS, settings_vector
from ..codegen.c_sensitivity import SUMMARY_FIELDS, sensitivity_source
from ..integrators import registry
from ..run.loading import load
from ..run.output import Result
from ..run.status import simulation_error
from .run import Directions, Program, SensitivityResult, prepare, result
from .variational import VariationalSystem


def integrate_c(program: Program, plan, chosen: Directions, times: np.ndarray | None = None,
                error_control: bool = True) -> SensitivityResult:
    """As run.integrate, the augmented system integrated by the generated C program."""
    return _run(program, library(program, plan.integrator, len(chosen.names), error_control), plan, chosen, times)


def library(program: Program, integrator, directions: int, error_control: bool = True):
    """The loaded C program for `directions` directions with `integrator` (an ir.IntegratorChoice),
    which `program.libraries` keeps by (integrator, directions, error control): built and compiled
    on first use (and cached by its text, run/cache.py)."""
    key = (integrator.name, directions, error_control)
    if key not in program.libraries:
        program.libraries[key] = load(sensitivity_source(program.kernel, integrator, directions,
                                                         program.model.source.name, error_control))
    return program.libraries[key]


def _run(program: Program, loaded, plan, chosen: Directions, times) -> SensitivityResult:
    start = prepare(program, plan, chosen, times)
    n, m = len(plan.coordinates), len(chosen.names)
    record = registry.get(plan.integrator.name)
    options = {**dict(record.defaults), **dict(plan.integrator.options)}
    began = clock.perf_counter()
    status, values, summary = call(loaded, start.system, augmented(start.y0, n, m), settings_of(plan, options),
                                   start.times)
    seconds = clock.perf_counter() - began
    at = {name: i for i, name in enumerate(SUMMARY_FIELDS)}
    counters = tuple((name, int(summary[at[name]])) for name in ("accepted", "rejected", "rhs_evals"))
    if status != 0:
        reached = first_order(summary[at["y_reached"]:][None, :], n, m)[0]
        done = int(summary[at["rows"]])
        partial = Result(start.times[:done], plan.columns, np.zeros((done, len(plan.columns))), None)
        raise simulation_error(plan.run_plan(), status, float(summary[at["t_reached"]]), reached[:2 * n],
                               partial, None)
    Y = first_order(values, n, m).T
    return result(program, plan, chosen, start.system, (start.times, Y), "c", counters, seconds, options)


def settings_of(plan, options: dict) -> np.ndarray:
    """The settings vector (abi.SETTINGS, then the atol of each state component) with `options`,
    the integrator's defaults and the plan's own, for rtol and atol."""
    settings = settings_vector(plan.run_plan())
    for name in ("rtol", "atol"):
        settings[SETTINGS.index(name)] = options[name]
    atol_each = plan.atol_vector(plan.coordinates)      # the state's own per component; the sensitivities keep atol
    settings[len(SETTINGS):] = options["atol"] if atol_each is None else atol_each
    return settings


def call(loaded, system: VariationalSystem, initial: np.ndarray, settings: np.ndarray,
         times: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """One run of lag_sensitivity_run from the augmented state `initial` at the settings' start
    time to each of `times`, with the parameters and J of `system`: (status, the augmented state
    at each time (rows, 2n(1 + m)), the summary (SUMMARY_FIELDS, then the state reached))."""
    width = initial.size
    values = np.zeros((len(times), width))
    summary = np.zeros(len(SUMMARY_FIELDS) - 1 + width)
    double_p = ctypes.POINTER(ctypes.c_double)
    entry = loaded.lag_sensitivity_run
    entry.argtypes = [double_p] * 5 + [ctypes.c_long, double_p, double_p, ctypes.c_void_p]
    entry.restype = ctypes.c_int
    loaded.lag_sensitivity_workspace.restype = ctypes.c_long
    # the stepper holds reals (double: the library is built in double precision), ints and longs
    workspace = np.zeros(loaded.lag_sensitivity_workspace() // 8 + 1)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in
              (system.par if system.par.size else np.zeros(1), system.J, initial, settings, times)]
    pointer = lambda a: a.ctypes.data_as(double_p)     # noqa: E731
    status = entry(*map(pointer, arrays), len(times), pointer(values), pointer(summary), workspace.ctypes.data)
    return int(status), values, summary


def augmented(y0: np.ndarray, n: int, m: int) -> np.ndarray:
    """(y, S by rows) -> (q, Sq_1 .. Sq_m, q', Sv_1 .. Sv_m)."""
    S = y0[2 * n:].reshape(2 * n, m)
    return np.concatenate([y0[:n], S[:n].T.ravel(), y0[n:2 * n], S[n:].T.ravel()])


def first_order(rows: np.ndarray, n: int, m: int) -> np.ndarray:
    """augmented's inverse, row by row: (rows, 2n(1 + m)) -> (rows, 2n + 2nm)."""
    count = len(rows)
    Q = rows[:, :n * (1 + m)].reshape(count, 1 + m, n)
    V = rows[:, n * (1 + m):].reshape(count, 1 + m, n)
    S = np.concatenate([Q[:, 1:].transpose(0, 2, 1), V[:, 1:].transpose(0, 2, 1)], axis=1)
    return np.concatenate([Q[:, 0], V[:, 0], S.reshape(count, -1)], axis=1)
