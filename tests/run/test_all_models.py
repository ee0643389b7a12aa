"""Every library model, with every integrator it admits (or a sample of them, see FULL_MATRIX),
on both backends, over a short span.

The radau5 path once failed to compile for most models (derivative names reached the
Jacobian block unrenamed) while the library's one radau5 scene did not exercise it; this
matrix keeps every combination alive. Each run is checked against the same model integrated
by dop853 in C at tight tolerances, so a wrong Jacobian, canonical form or projection shows
up as disagreement, not only as a crash.

Cost: each (model, integrator, backend) is generated when its first test runs; the build cache
keeps its source (codegen/kept.py) and C library for every later test and run of the suite. Most
cases are marked slow (`pytest --slow`); the default run keeps DEFAULT_CASES and GAUSS_DEFAULT.
Nothing is loaded or derived at collection: whether rkn8 applies (accelerations free of the
velocities) is known only after the derivation, so a case that it refuses checks the refusal.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

import lagdsl
from lagdsl.integrators import registry
from lagdsl.run.output import Result
from lagdsl.scene import Overrides
from tests.conftest import MODELS, library_model

STOP = 0.1
ROWS = 10                               # output intervals over the span
FIXED_STEP = 1e-3                       # rk4 and gauss: global error ~ h^4 = 1e-12
# Models that move on a faster time scale than the others run over a proportionally shorter
# span with a proportionally smaller fixed step: Andrews' mechanism turns its crank at up to
# 1000 rad/s within its 0.03 s scene; the relativistic electron runs one turn.
SPANS = {"andrews": 0.003, "relativistic_cyclotron": 4.2e-11}     # the electron turns in 4.2e-11 s
TIGHT = (("rtol", 1e-10), ("atol", 1e-12))
AGREEMENT = 1e-6
REFERENCE = ("dop853", "c")
# Models that must refuse gauss, and why (the rule: no constraints, L quadratic in q', M independent of q').
REFUSES_GAUSS = {model: "constraints" for model in (
    "andrews", "atwood", "car_axis", "cartesian_chain", "cartesian_pendulum", "chaplygin_sledge", "ladder", "rolling_disk",
    "rolling_penny", "sphere_two_bodies_cartesian")} | {"relativistic_cyclotron": "quadratic in the velocities"}
# The NumPy backend refuses auto with constraints: it would restart its scipy solver, and so its
# stiffness test and switches, after every projection.
CONSTRAINED = {model for model, reason in REFUSES_GAUSS.items() if reason == "constraints"}
MODEL_NAMES = sorted(path.stem for path in MODELS.glob("*.lag"))
# Every integrator on these models, which between them hold every kind of structure the code
# generators handle (holonomic, nonholonomic and rheonomic constraints, indexed families, a
# velocity-dependent L, forces and dissipation, stiffness). Every other library model runs with
# the reference, radau5 (whose generated Jacobian is the most model-specific code) and one more
# integrator in turn, so that each integrator still meets several of them: the full matrix over
# all thirty-odd models took 95 s of CPU (seven minutes on the loaded test machine) for little
# more coverage.
FULL_MATRIX = {"andrews", "car_axis", "cartesian_pendulum", "charged_particle", "damped_driven_pendulum",
               "double_pendulum", "driven_support", "elastic_pendulum", "fermi_pasta_ulam", "heavy_top", "kepler",
               "particle_3d", "pendulum_chain", "rolling_penny", "wedge"}
# The 200-mass chain runs with the explicit integrators of its loops (codegen/loops.py) only:
# radau5 and gauss take the expanded equations of 200 coordinates, seconds of derivation and a
# 400 x 400 Jacobian, and tests/mechanics/test_families.py checks that fallback on a short chain.
LOOPED_ONLY = {"fpu_chain": ("dop853", "dopri5")}
# taylor runs on every other model: its series come from the equations' own operations, so
# each model's mix of functions, constraints and mass matrix is a case of its own.
EVERYWHERE = ("taylor",)
SAMPLED = [model for model in MODEL_NAMES if model not in FULL_MATRIX and model not in LOOPED_ONLY]
IN_TURN = ("rk4", "dopri5", "gauss", "auto")


load = library_model


def refuses(integrator: str, model: str) -> bool:
    """gauss refuses constraints; rkn8 refuses them too (and accelerations that read velocities,
    see reads_velocities)."""
    if integrator == "gauss":
        return model in REFUSES_GAUSS
    if integrator == "rkn8":
        return model in CONSTRAINED
    return False


def reads_velocities(model: str) -> bool:
    return bool(load(model).equations.velocity_in_accelerations)


def integrators(model: str) -> tuple[str, ...]:
    """The integrators a model runs with here (gauss and rkn8 only where their rules admit them)."""
    if model in LOOPED_ONLY:
        return LOOPED_ONLY[model]
    if model in FULL_MATRIX:
        chosen = registry.names()
    else:
        chosen = ("dop853", "radau5", IN_TURN[SAMPLED.index(model) % len(IN_TURN)], *EVERYWHERE)
    return tuple(name for name in chosen if not refuses(name, model))


# The default run (the rest is marked slow): every integrator on the double pendulum (rkn8 checks
# its refusal), rkn8 on a model it takes, a constrained model with projection.
DEFAULT_CASES = {*(("double_pendulum", name) for name in registry.names()), ("wedge", "rkn8"),
                 ("rolling_penny", "dopri5")}
CASES = [pytest.param(model, integrator, marks=() if (model, integrator) in DEFAULT_CASES else pytest.mark.slow)
         for model in MODEL_NAMES for integrator in integrators(model)]
# The gauss rule on the default run: the models it refuses (cheap: refused at planning) and two it takes.
GAUSS_DEFAULT = {*REFUSES_GAUSS, "double_pendulum", "kepler"}


def span(model: str) -> float:
    return SPANS.get(model, STOP)


def options(integrator: str, model: str) -> tuple[tuple[str, float], ...]:
    return (("step", FIXED_STEP * span(model) / STOP),) if integrator in ("rk4", "gauss") else TIGHT


@functools.cache
def run(model: str, integrator: str, backend: str) -> Result:
    """A case run through the API: its program generated once, and its generated source kept
    across runs of the suite (codegen/kept.py)."""
    return load(model).simulate(None, backend, start=0.0, stop=span(model), interval=span(model) / ROWS,
                                integrator=integrator, **dict(options(integrator, model)))


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("model, integrator", CASES)
def test_model_runs_and_agrees_with_dop853(model, integrator, backend):
    if integrator == "rkn8" and reads_velocities(model):
        with pytest.raises(lagdsl.LagError, match="rkn8 needs accelerations that do not depend on the velocities"):
            load(model).plan(None, Overrides(integrator=integrator))
        return
    if (integrator, backend) == ("auto", "numpy") and model in CONSTRAINED:
        with pytest.raises(lagdsl.LagError, match="restarts its scipy solver after every projection"):
            run(model, integrator, backend)
        return
    if (integrator, backend) == ("taylor", "numpy"):
        with pytest.raises(lagdsl.LagError, match="--backend c"):
            run(model, integrator, backend)
        return
    result = run(model, integrator, backend)
    assert result.t[-1] == pytest.approx(span(model)) and len(result.t) == ROWS + 1
    assert np.all(np.isfinite(result.values))
    reference = run(model, *REFERENCE)
    scale = 1 + np.max(np.abs(reference.values), axis=0)
    deviation = np.max(np.abs(result.values - reference.values), axis=0) / scale
    worst = int(np.argmax(deviation))
    assert deviation[worst] < AGREEMENT, f"{result.columns[worst]} deviates by {deviation[worst]:.2g}"


@pytest.mark.parametrize("model", [pytest.param(model, marks=() if model in GAUSS_DEFAULT else pytest.mark.slow)
                                   for model in MODEL_NAMES])
def test_gauss_is_refused_exactly_where_the_rule_says(model):
    overrides = Overrides(integrator="gauss", options=options("gauss", model))
    if model in REFUSES_GAUSS:
        with pytest.raises(lagdsl.LagError, match=REFUSES_GAUSS[model]):
            load(model).emit("c", None, overrides)
    else:
        assert "lag_hamilton_rhs" in load(model).emit("c", None, overrides).text
