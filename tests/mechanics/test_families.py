"""The local form of large models (mechanics/families.py, codegen/loops.py): equations derived
once per shape and lowered to loops over the members.

Checked against the expanded equations (derive_equations) at random states, for a diagonal and
a banded mass matrix; the code must not grow with the number of members; and the scenes the
local form does not serve (implicit and symplectic integrators, momenta) fall back to the
expanded equations and still agree.
"""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from lagdsl.codegen.kernel import lower_to_kernel
from lagdsl.mechanics import derive_equations
from lagdsl.mechanics.families import LocalEquations, derive_local_equations
from lagdsl.pipeline import execute, generate, load_model, model_from_source, plan
from lagdsl.run.loading import load
from lagdsl.scene import Overrides
from lagdsl.source import SourceFile
from tests.conftest import MODELS


def library_text(name: str, **sizes: int) -> str:
    """A library model's text with its structural parameters set (`parameter m = 100` -> m)."""
    text = (MODELS / f"{name}.lag").read_text()
    for parameter, value in sizes.items():
        start = text.index(f"parameter {parameter} = ")
        end = text.index(" ", start + len(f"parameter {parameter} = "))
        text = text[:start] + f"parameter {parameter} = {value}" + text[end:]
    return text


def compiled(text: str, name: str = "model.lag"):
    model = model_from_source(SourceFile(name, text))
    return model, derive_local_equations(model)


@pytest.mark.parametrize("name, sizes, bandwidth", [("fpu_chain", {"m": 10}, 0), ("fem_string_fine", {"N": 24}, 1)])
def test_local_form_gives_the_expanded_equations(name, sizes, bandwidth):
    model, local = compiled(library_text(name, **sizes))
    assert isinstance(local, LocalEquations) and local.bandwidth == bandwidth
    expanded = derive_equations(model)
    scene = plan(model, local, None, Overrides())
    looped = load(generate(local, scene, "numpy", "m.lag")[1])
    unrolled = load(generate(expanded, scene, "numpy", "m.lag")[1])
    par = looped.default_parameters()
    states = np.random.default_rng(1).normal(size=(2 * local.size, 5))
    assert np.allclose(looped.accelerations(par, 0.3, states)[0], unrolled.accelerations(par, 0.3, states)[0],
                       rtol=1e-12, atol=1e-12)
    out_looped, inv_looped = looped.observables(0.3, states, par)
    out_unrolled, inv_unrolled = unrolled.observables(0.3, states, par)
    assert np.allclose(out_looped, out_unrolled, rtol=1e-12, atol=1e-12)
    assert np.allclose(inv_looped, inv_unrolled, rtol=1e-12, atol=1e-12)


DAMPED_CHAIN = """model DampedChain
  parameter k = 2;  parameter c = 0.1;  parameter F = 0.3;  parameter w[20] = {1 + i/10, i in 1:20};
  coordinate x[20](start = {0.01*i, i in 1:20}, velocity = {0.1*cos(i), i in 1:20});
  T = sum(w[i]*der(x[i])^2/2, i in 1:20);
  U = k/2*(x[1]^2 + sum((x[i + 1] - x[i])^2 + cos(t)*x[i]*x[i + 1]/10, i in 1:19)) + 3.5 + sin(t);
  dissipation = c/2*sum(der(x[i])^2, i in 1:20);
  force x[20] = F*cos(t);
  scene drive
    output x[1], x[20], energy;
  end drive;
end DampedChain;
"""


def test_local_form_takes_dissipation_forces_parameter_arrays_time_and_constant_terms():
    model, local = compiled(DAMPED_CHAIN)
    assert isinstance(local, LocalEquations) and local.conserved == ()
    expanded = derive_equations(model)
    scene = plan(model, local, None, Overrides())
    looped = load(generate(local, scene, "numpy", "m.lag")[1])
    unrolled = load(generate(expanded, scene, "numpy", "m.lag")[1])
    par = looped.default_parameters()
    states = np.random.default_rng(2).normal(size=(40, 3))
    for t in (0.0, 0.7):
        assert np.allclose(looped.accelerations(par, t, states)[0], unrolled.accelerations(par, t, states)[0],
                           rtol=1e-12, atol=1e-12)
        assert np.allclose(looped.observables(t, states, par)[0], unrolled.observables(t, states, par)[0],
                           rtol=1e-12, atol=1e-12)
    short = plan(model, local, None, Overrides(stop=1.0))
    c, numpy = (execute(generate(local, short, backend, "m.lag")[1], short) for backend in ("c", "numpy"))
    assert np.allclose(c.values, numpy.values, rtol=1e-6, atol=1e-8)


def test_generated_code_does_not_grow_with_the_members():
    def assemble_lines(m: int) -> int:
        model, local = compiled(library_text("fpu_chain", m=m))
        text = generate(local, plan(model, local, None, Overrides()), "c", "m.lag")[1].text
        start = text.index("static void lag_assemble(")
        return text[start:text.index("\n}\n", start)].count("\n")

    assert assemble_lines(20) == assemble_lines(200)


def test_small_constrained_and_dense_models_keep_the_expanded_equations():
    for name in ("fermi_pasta_ulam", "cartesian_pendulum", "pendulum_chain", "pleiades"):
        assert derive_local_equations(load_model(MODELS / f"{name}.lag")) is None, name


def test_a_singular_mass_matrix_is_reported_by_the_expanded_derivation():
    """T = Σ (q'_i - q'_{i+1})²/2 leaves the common velocity free: M is singular."""
    text = """model Free
  coordinate x[20];
  T = sum((der(x[i]) - der(x[i + 1]))^2/2, i in 1:19);
  U = sum(x[i]^2, i in 1:20);
end Free;
"""
    model, local = compiled(text)
    assert local is None
    with pytest.raises(lagdsl.LagError, match="mass matrix is singular at every state"):
        derive_equations(model)


@pytest.mark.parametrize("integrator, loops", [pytest.param("radau5", True, marks=pytest.mark.slow), ("gauss", False)])
def test_implicit_scenes_loop_when_m_is_constant_and_gauss_uses_the_expanded_equations(integrator, loops):
    """radau5 needs ∂f/∂(q, q') and M, which the stencils give (M is constant here); gauss needs
    the canonical form, which only the expanded equations give. Both agree with dop853."""
    model, local = compiled(library_text("fpu_chain", m=8))
    options = (("step", 1e-3),) if integrator == "gauss" else ()
    scene = plan(model, local, None, Overrides(stop=0.2, integrator=integrator, options=options))
    kernel = lower_to_kernel(local, scene)
    assert bool(kernel.system and kernel.system.loops) == loops
    assert bool(kernel.jacobian and kernel.jacobian.loops) == loops
    reference = plan(model, local, None, Overrides(stop=0.2))
    looped = lower_to_kernel(local, reference)
    assert looped.system.loops
    fallback = execute(generate(local, scene, "c", "m.lag")[1], scene)
    direct = execute(generate(local, reference, "c", "m.lag")[1], reference)
    assert np.allclose(fallback.values, direct.values, atol=1e-7)
