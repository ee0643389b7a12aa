"""--integrator and its options: the scene's settings carry over where they apply, the summary
shows what was used, and mistakes in an option are reported at the option."""
from __future__ import annotations

import subprocess

import pytest

import lagdsl
from lagdsl.errors import LagError
from lagdsl.scene import Overrides
from tests.conftest import MODELS, library_model
from tests.test_cli import lagc


def plan(model: str, **overrides):
    return library_model(model).plan(None, Overrides(**overrides))


def test_another_method_keeps_the_scenes_tolerances():
    # cartesian_pendulum's scene: dop853(rtol = 1e-10, atol = 1e-12)
    options = dict(plan("cartesian_pendulum", integrator="radau5").integrator.options)
    assert options == {"rtol": 1e-10, "atol": 1e-12}
    options = dict(plan("cartesian_pendulum", integrator="dopri5", options=(("rtol", 1e-6),)).integrator.options)
    assert options == {"rtol": 1e-6, "atol": 1e-12}


def test_option_errors_point_at_the_option():
    cases = [(dict(integrator="gauss", options=(("step", 0.01),)), "lagc: error: --integrator gauss: "
              "the symplectic gauss integrator does not handle constraints; use radau5 or dop853"),
             (dict(options=(("rtol", -1.0),)), "lagc: error: --rtol: dop853(rtol = ...) must be a finite number >= 0"),
             (dict(integrator="rk4"), "lagc: error: --integrator rk4: rk4 is a fixed-step method and needs "
              "a step: --step 0.001"),
             (dict(options=(("stages", 3.0),)), "lagc: error: --stages: dop853 has no option 'stages' "
              "(options: rtol, atol, max_step, max_steps)"),
             (dict(integrator="rk5"), "lagc: error: --integrator rk5: unknown integrator 'rk5'; did you "
              "mean 'rk4'? (available: rk4, dopri5, dop853, rkn8, radau5, gauss, taylor, auto)")]
    for overrides, message in cases:
        with pytest.raises(LagError) as caught:
            plan("cartesian_pendulum", **overrides)
        assert caught.value.render() == message


def test_scene_option_errors_point_at_the_value(tmp_path):
    path = tmp_path / "bad.lag"
    path.write_text("""model Bad
  coordinate x;
  T = der(x)^2/2;
  scene s
    integrator gauss(step = 0.1, stages = 7);
  end s;
end Bad;
""", encoding="utf-8")
    with pytest.raises(LagError) as caught:
        lagdsl.load(path)
    (diagnostic,) = caught.value.diagnostics
    assert (diagnostic.span.line, diagnostic.span.column) == (5, 43)


@pytest.mark.parametrize("backend", ["c", pytest.param("numpy", marks=pytest.mark.slow)])
def test_the_summary_shows_the_settings_used(tmp_path, backend):
    done = lagc("run", MODELS / "cartesian_pendulum.lag", "--backend", backend, "--integrator", "radau5",
                "--stop", "0.1", "-o", tmp_path / "out.csv")
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith(f"integrator radau5(rtol = 1e-10, atol = 1e-12) ({backend}): ")
    done = lagc("run", MODELS / "kepler.lag", "--backend", backend, "--integrator", "gauss", "--step", "0.01",
                "--stop", "0.1", "-o", tmp_path / "out.csv")
    assert done.returncode == 0, done.stderr
    assert done.stderr.startswith(f"integrator gauss(step = 0.01, stages = 2) ({backend}): ")


def test_the_c_program_prints_the_settings_it_used(tmp_path):
    source = library_model("cartesian_pendulum").emit("c")
    program = tmp_path / "pendulum"
    (tmp_path / "pendulum.c").write_text(source.text, encoding="utf-8")
    # -O0: the program's words are what is checked, and it compiles in a fraction of the time
    subprocess.run(["cc", "-std=c99", "-O0", "-o", program, tmp_path / "pendulum.c", "-lm"], check=True)
    done = subprocess.run([program, "t.stop=0.1", "--rtol=1e-9", "--max_step=0.01"], capture_output=True, text=True)
    assert done.returncode == 0
    assert done.stderr.startswith("integrator dop853(rtol = 1e-09, atol = 1e-12, max_step = 0.01): ")


def test_rkn8_refuses_accelerations_that_read_velocities_and_constraints(tmp_path):
    """The Nystrom pair integrates q'' = a(t, q): the double pendulum's M changes with the angles,
    so its f holds the velocities squared; a damped oscillator's f reads der(x); a constrained
    model is refused before any derivation, as gauss is."""
    def refusal(model, **overrides):
        with pytest.raises(LagError) as caught:
            lagdsl.load(model).simulate(integrator="rkn8", stop=0.1, **overrides)
        return caught.value.render()

    assert refusal(MODELS / "double_pendulum.lag") == (
        "lagc: error: --integrator rkn8: the Nystrom integrator rkn8 needs accelerations that do not depend on "
        "the velocities, and der(theta1) appears in this model's equations of motion (through a mass matrix "
        "that changes with the coordinates, dissipation, or a velocity-dependent force); use dop853")
    damped = tmp_path / "damped.lag"
    damped.write_text("model Damped\n  coordinate x(start = 1);\n  T = der(x)^2/2;\n  U = x^2/2;\n"
                      "  dissipation = 0.1*der(x)^2/2;\nend Damped;\n", encoding="utf-8")
    assert "der(x) appears" in refusal(damped)
    assert refusal(MODELS / "cartesian_pendulum.lag") == (
        "lagc: error: --integrator rkn8: the Nystrom integrator rkn8 does not handle constraints; use dop853 "
        "or radau5")


def test_rkn8_refuses_a_damped_chain_in_the_local_form(tmp_path):
    """The local form (loops over members) finds the velocity a stencil's forcing reads."""
    chain = tmp_path / "chain.lag"
    chain.write_text("model Chain\n  coordinate q[40](start = {1" + ", 0" * 39 + "});\n"
                     "  T = sum(der(q[i])^2/2, i in 1:40);\n  U = sum((q[i + 1] - q[i])^2/2, i in 1:39);\n"
                     "  dissipation = sum(0.1*der(q[i])^2/2, i in 1:40);\nend Chain;\n", encoding="utf-8")
    with pytest.raises(LagError, match=r"der\(q\[1\]\) appears in this model's equations of motion"):
        lagdsl.load(chain).simulate(integrator="rkn8", stop=0.1)
