"""The integrators lagdsl bundles: one record each, read by every stage.

A record says what a method is (its options with their checks, its work counters, its traits),
where it lives (its C files, its NumPy-backend stepper or scipy equivalent) and how it is
described to users. Settings, planning, code generation, both runners, the sweep, the bench and
the command line all read these records; adding an integrator is one `register(Integrator(...))`
and its sources. Nothing here imports numpy or sympy.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction


@dataclass(frozen=True)
class Option:
    """An integrator option: its meaning, the values it takes (in Python and in C) and its C type."""

    name: str
    meaning: str                        # help text
    requirement: str                    # the values it takes, in words
    accepts: Callable[[float], bool]    # the check, in Python
    c_accepts: str                      # the same check in C, on a double `value`
    c_cast: str = ""                    # how the standalone program stores it: "", "(int)", "(long)"
    time: bool = False                  # a time: in seconds, or written with a unit of time
    choices: tuple[str, ...] = ()       # a word among these, written as the word, held as its index

    def word(self, value: float) -> str:
        """How a scene and the run summary write `value`: the word of its index, else the number."""
        return self.choices[int(value)] if self.choices else format(value, "g")

    @property
    def number_requirement(self) -> str:
        """The values it takes as numbers, where its words are indices (the standalone program's
        --norm=1, an FMU's Integer): "0 (component) or 1 (state)"."""
        indices = [f"{index} ({word})" for index, word in enumerate(self.choices)]
        return ", ".join(indices[:-1]) + " or " + indices[-1] if indices else self.requirement

    @property
    def flag(self) -> str:
        """Its name on a command line, lagc's or the standalone program's: --max-step."""
        return self.name.replace("_", "-")


# The largest step limit: the most a run may be given (--max-steps), and the most a fixed step implies.
MAX_STEPS_CEILING = 10**15
# An adaptive run's step limit unless the grid asks for more (settings.step_limit): a budget the work
# forecast (integrators/forecast.py) holds the run's pace to.
DEFAULT_MAX_STEPS = 10**7


def _count(number: int) -> str:
    """1e15 and 1e7, not 1e+15 and 1e+07."""
    mantissa, exponent = f"{number:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


OPTIONS: dict[str, Option] = {option.name: option for option in (
    Option("rtol", "relative tolerance (adaptive integrators)", "a finite number >= 0",
           lambda v: 0 <= v < math.inf, "r_isfinite(value) && value >= 0"),
    Option("atol", "absolute tolerance (adaptive integrators)", "a finite number >= 0",
           lambda v: 0 <= v < math.inf, "r_isfinite(value) && value >= 0"),
    Option("step", "the step (fixed-step integrators)", "a finite number > 0",
           lambda v: 0 < v < math.inf, "r_isfinite(value) && value > 0", time=True),
    Option("max_step", "the largest step an adaptive integrator may take", "a finite number > 0",
           lambda v: 0 < v < math.inf, "r_isfinite(value) && value > 0", time=True),
    Option("stages", "Gauss-Legendre stages (gauss: order 2s)", "a whole number from 1 to 6",
           lambda v: 1 <= v <= 6 and v == int(v), "value >= 1 && value <= 6 && value == r_floor(value)", "(int)"),
    Option("max_steps", "the step limit (accepted + rejected steps): none by default for a fixed step; "
                        f"for an adaptive method {_count(DEFAULT_MAX_STEPS)} (more for a long output grid), and a run "
                        "whose pace forecasts more stops early, naming the forecast",
           "a whole number from 1 to " + _count(MAX_STEPS_CEILING),
           lambda v: 1 <= v <= MAX_STEPS_CEILING and v == int(v),
           "value >= 1 && value <= (real)LAG_MAX_STEPS_CEILING && value == r_floor(value)", "(long)"),
    Option("norm", "the norm of the Taylor integrator's step control: component (the default; each component "
                   "against atol_i + rtol |y_i|, for states that mix units) or state (Jorba and Zou's: the whole "
                   "state's largest coefficient against atol + rtol max_i |y_i|, for states on one scale)",
           "component or state", lambda v: v in (0, 1), "value == 0 || value == 1", "(int)",
           choices=("component", "state")),
)}
# The order of the options in lag_options, the settings array of lag_run and the run summary.
OPTION_ORDER = ("rtol", "atol", "step", "max_step", "stages", "norm", "max_steps")
ADAPTIVE_OPTIONS = ("rtol", "atol", "max_step", "max_steps")
ADAPTIVE_DEFAULTS = (("rtol", 1e-8), ("atol", 1e-10))


@dataclass(frozen=True)
class Integrator:
    """One bundled method.

    `counters` are the fields of the lag_stats its C file defines, in the order the run summary
    reports them. `python` is the NumPy backend's stepper, "module:function" in
    lagdsl.integrators.python with the signature of `run.numpy_backend.Stepper`; `scipy` the
    scipy.integrate solver that stands for it there instead (a composite steps its parts'
    solvers: scipy_solvers).
    """

    name: str
    title: str                                  # "the Nystrom integrator rkn8": how messages name it
    description: str                            # one line for help texts
    options: tuple[str, ...] = ADAPTIVE_OPTIONS
    defaults: tuple[tuple[str, float], ...] = ADAPTIVE_DEFAULTS
    counters: tuple[str, ...] = ("accepted", "rejected", "rhs_evals")
    fixed_step: bool = False                    # needs `step`; never rejects a step
    implicit: bool = False                      # needs the Jacobian (and a positive atol)
    canonical: bool = False                     # integrates Hamilton's equations (symplectic)
    second_order: bool = False                  # q'' = a(t, q) only: no velocity in M or f
    constraints: str | None = None              # None if it handles constraints, else the remedy
    stability_boundary: float = 0.0             # |h lambda| beyond which its steps are held by stability ...
    # ... (HNW I, IV.2); an explicit pair with one runs the stiffness test (c/stiffness_test.c)
    parts: tuple[str, ...] = ()                 # a composite: the methods it switches between
    c_fragments: tuple[str, ...] = ()           # shared C files pasted before its own
    c_protocol: tuple[str, ...] = ()            # shared C files pasted after it, which use what it defines
    scipy: str | None = None                    # NumPy backend: the scipy.integrate solver
    python: str | None = None                   # NumPy backend: our own stepper
    numpy_constraints: str | None = None        # why the NumPy backend refuses it with constraints
    numpy: str | None = None                    # why the NumPy backend refuses it at all
    series: bool = False                        # steps by the Taylor series of the equations (codegen/c_taylor.py)
    stacks_in_sweeps: bool = False              # NumPy sweeps integrate chunks of members as one system
    lanes: str = ""                             # its C file that runs a sweep's members in SIMD lanes, if any
    source: str = ""                            # its C file, if not NAME.c
    order: int = 0                              # the order of the method (per stage if stage_order)
    stage_order: bool = False                   # gauss: order = order x stages
    # The tolerances it works to: rtol' = tolerance_scale rtol^tolerance_power, atol' = rtol' atol / rtol
    # (radau5, as Hairer's RADAU5: its error estimate is O(h^4) while the method has order 5, and
    # this keeps the global error roughly proportional to rtol). Its scipy equivalent is given the same.
    tolerance_scale: float = 1.0
    tolerance_power: Fraction = Fraction(1)           # a fraction, so that C has it in every precision

    def working_tolerances(self, rtol: float, atol):
        """(rtol', atol'): the tolerances the method's error test uses for the user's (rtol, atol);
        atol may be one number or an array of one per component."""
        if not self.transforms_tolerances:
            return rtol, atol
        working = self.tolerance_scale * rtol ** float(self.tolerance_power)
        return working, working * (atol / rtol)

    @property
    def transforms_tolerances(self) -> bool:
        return (self.tolerance_scale, self.tolerance_power) != (1.0, 1)

    def order_with(self, options: dict[str, float]) -> int:
        """The method's order with `options` (gauss: 2 per stage)."""
        return self.order * int(options["stages"]) if self.stage_order else self.order

    @property
    def stiffness_test(self) -> bool:
        """It reports the explicit pairs' stiffness test."""
        return self.stability_boundary > 0

    @property
    def scipy_solvers(self) -> tuple[str, ...]:
        """The scipy.integrate solvers that step it on the NumPy backend: its `scipy`, or a
        composite's parts', between which integrators/python/auto.py switches by the rule of
        auto.c; () for a method with a Python stepper of its own."""
        if self.parts:
            return tuple(get(part).scipy for part in self.parts)
        return (self.scipy,) if self.scipy else ()

    @property
    def adaptive(self) -> bool:
        return not self.fixed_step

    @property
    def c_file(self) -> str:
        return self.source or f"{self.name}.c"

    def refusal(self, backend: str, constrained: bool) -> str | None:
        """Why a scene with (or without) constraints cannot run this method on `backend`, or None."""
        if constrained and self.constraints is not None:
            return f"{self.title} does not handle constraints; {self.constraints}"
        if backend == "numpy" and self.numpy is not None:
            return self.numpy
        if constrained and backend == "numpy" and self.numpy_constraints is not None:
            return self.numpy_constraints
        return None


_REGISTRY: dict[str, Integrator] = {}


def register(integrator: Integrator) -> Integrator:
    """Add `integrator` (or replace the one of its name); every stage sees it from then on."""
    unknown = [option for option in integrator.options if option not in OPTIONS]
    if unknown:
        raise ValueError(f"integrator {integrator.name}: unknown option {unknown[0]!r}")
    _REGISTRY[integrator.name] = integrator
    return integrator


def unregister(name: str) -> None:
    _REGISTRY.pop(name, None)


def names() -> tuple[str, ...]:
    return tuple(_REGISTRY)


def get(name: str) -> Integrator:
    """The record of `name` (a KeyError for an unknown name: callers check names first)."""
    return _REGISTRY[name]


def known(name: str) -> bool:
    return name in _REGISTRY


# The explicit pairs: step-size control before, the step protocol after (the Dormand-Prince pairs
# have a stiffness test, and share their start, acceptance and restart).
_DORMAND_PRINCE = ("explicit_control.c", "stiffness_test.c")
_DORMAND_PRINCE_STEP = ("dormand_prince.c", "explicit_step.c")
_EXPLICIT_STEP = ("explicit_step.c",)
for _record in (
    Integrator("rk4", "the classical Runge-Kutta method rk4", "classical Runge-Kutta, order 4, fixed step",
               options=("step", "max_steps"), defaults=(), counters=("accepted", "rhs_evals"), fixed_step=True,
               c_fragments=("fixed_step.c",), python="fixed_step:run_rk4", order=4),
    Integrator("dopri5", "the Dormand-Prince pair dopri5", "Dormand-Prince 5(4), adaptive, dense output of order 4",
               stability_boundary=3.25, c_fragments=_DORMAND_PRINCE, c_protocol=_DORMAND_PRINCE_STEP, scipy="RK45",
               stacks_in_sweeps=True, order=5),
    Integrator("dop853", "the Dormand-Prince pair dop853",
               "Dormand-Prince 8(5,3), adaptive, dense output of order 7 (the default)",
               stability_boundary=6.1, c_fragments=_DORMAND_PRINCE, c_protocol=_DORMAND_PRINCE_STEP, scipy="DOP853",
               stacks_in_sweeps=True, lanes="dop853_lanes.c", order=8),
    Integrator("rkn8", "the Nystrom integrator rkn8",
               "Runge-Kutta-Nystrom 8(6) for q'' = a(t, q), adaptive (no velocity-dependent forces)",
               second_order=True, constraints="use dop853 or radau5", c_fragments=("explicit_control.c",),
               c_protocol=_EXPLICIT_STEP,
               python="nystrom:run_rkn8", order=8),
    Integrator("radau5", "the implicit Radau IIA method radau5", "Radau IIA order 5, implicit, for stiff models",
               counters=("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"),
               implicit=True, scipy="Radau", order=5, tolerance_scale=0.1,
               tolerance_power=Fraction(2, 3)),
    Integrator("gauss", "the symplectic gauss integrator",
               "Gauss-Legendre collocation of order 2s, symplectic, fixed step",
               options=("stages", "step", "max_steps"), defaults=(("stages", 2),),
               counters=("accepted", "rhs_evals", "newton_iters"), fixed_step=True, canonical=True,
               constraints="use radau5 or dop853", c_fragments=("fixed_step.c",), python="fixed_step:run_gauss",
               order=2, stage_order=True),
    Integrator("taylor", "the Taylor integrator taylor",
               "Taylor series of variable order and step (Jorba-Zou), from the equations' recurrences; C backend",
               options=(*ADAPTIVE_OPTIONS, "norm"),
               counters=("accepted", "orders"), series=True, lanes="taylor_lanes.c",
               numpy="the Taylor integrator taylor runs on the C backend only (its series are generated C); "
                     "use --backend c, or dop853 on the NumPy backend"),
    Integrator("auto", "auto", "dop853, switching to radau5 where the model is stiff, and back",
               counters=("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"),
               implicit=True, parts=("dop853", "radau5"), order=5,
               numpy_constraints="auto on the NumPy backend restarts its scipy solver after every projection "
                                 "onto the constraints, which would begin its stiffness test and its switches "
                                 "anew each step; use --backend c, or --integrator dop853 or radau5"),
):
    register(_record)
