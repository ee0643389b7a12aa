"""Trees with loops closed by holonomic constraints (mechanics/trees.py, the Schur complement
of lag_solve in templates/c/model.c.j2): a chain whose last bob is pinned to a point or slides
on a line, solved through the articulated-body factor of M, against the expanded equations'
dense saddle-point solve (itself checked against the textbook in tests/models/test_constrained.py):
the same trajectory, multipliers and residuals to 1e-10 of their size, the generated C
compiled strictly; and chains with joint dampers and forces on single joints (their τ_j).

The closed chain is chaotic and snaps (its multipliers jump tenfold within 0.05 s): rounding
differences of the two solves grow with time and n, and at rtol 1e-10 the two runs' different
steps alone part their interpolated multipliers by 4e-10 of their size at a snap. So the scene
runs at rtol 1e-12 (then 1e-11 after 2 s of the 8-link chain), the 16-link chain over 1 s.
"""
from __future__ import annotations

import pytest

from lagdsl.mechanics.trees import TreeEquations, derive_tree_equations
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile
from tests.conftest import model_file
from tests.mechanics.test_trees import assert_follows, chain_text, run_dense, run_scene
from tests.run.c_harness import build_scene_programs

PIN = "constraint ex: x[n] = span;\n  constraint ey: y[n] = drop;"
SLIDE = "constraint ey: y[n] = drop;"


def closed_chain_text(n: int, seconds: float, constraints: str = PIN) -> str:
    """An n-link chain of unequal masses and lengths hung from the origin, released from rest
    with its links' angles evenly spread from 1.2 to -1.2 rad, its last bob held by `constraints`
    where that start puts it: pinned at (span, drop), or sliding on the line y = drop."""
    outputs = "theta[1], theta[n], x[n/2], energy, multiplier(ey), residual(ey)"
    if "ex" in constraints:
        outputs += ", multiplier(ex)"
    return f"""model ClosedChain
  parameter n = {n};
  parameter m[n] = {{1 + 1/i, i in 1:n}};
  parameter l[n] = {{1 - i/(3*n), i in 1:n}};
  parameter g = 9.81;
  parameter span = sum(l[i]*sin(1.2 - 2.4*(i - 0.5)/n), i in 1:n);
  parameter drop = -sum(l[i]*cos(1.2 - 2.4*(i - 0.5)/n), i in 1:n);
  coordinate theta[n](start = {{1.2 - 2.4*(i - 0.5)/n, i in 1:n}}, velocity = 0);
  let x[i] = sum(l[j]*sin(theta[j]), j in 1:i), i in 1:n;
  let y[i] = -sum(l[j]*cos(theta[j]), j in 1:i), i in 1:n;
  T = sum(m[i]/2*(der(x[i])^2 + der(y[i])^2), i in 1:n);
  U = sum(m[i]*g*y[i], i in 1:n);
  {constraints}
  scene swing
    time(stop = {seconds}, interval = 0.05);
    integrator dop853(rtol = 1e-12, atol = 1e-14);
    output {outputs};
  end swing;
end ClosedChain;
"""


# The default run keeps both kinds of closure on 8 links; 16 links (its dense path derived
# symbolically for 14 s of CPU) is the size case, slow.
@pytest.mark.parametrize("n, seconds, constraints", [(8, 2, PIN), pytest.param(16, 1, PIN, marks=pytest.mark.slow),
                                                     (8, 2, SLIDE)],
                         ids=["pinned 8", "pinned 16", "sliding 8"])
def test_closed_chain_follows_the_dense_trajectory_and_multipliers(n, seconds, constraints):
    model = model_from_source(SourceFile("closed.lag", closed_chain_text(n, seconds, constraints)))
    tree = derive_tree_equations(model)
    assert isinstance(tree, TreeEquations) and tree.parents == (-1, *range(n - 1))
    assert [c.name for c in tree.active_constraints] == [c.name for c in model.constraints]
    assert tree.conserved                                   # the constraints do not depend on t
    kernel, looped = run_scene(model, tree, "swing")
    assert kernel.layout.kind == "tree" and kernel.constraints == tuple(c.name for c in model.constraints)
    assert_follows(looped, run_dense(model))


def test_a_moving_pin_leaves_the_energy_unconserved():
    text = closed_chain_text(8, 1, SLIDE).replace("y[n] = drop;", "y[n] = drop + 0.1*sin(t);")
    tree = derive_tree_equations(model_from_source(SourceFile("closed.lag", text)))
    assert isinstance(tree, TreeEquations) and not tree.conserved


def test_a_velocity_constraint_takes_the_expanded_equations():
    text = closed_chain_text(8, 1, "constraint roll: der(x[n]) = 0;").replace(
        "multiplier(ey), residual(ey)", "multiplier(roll)")
    assert derive_tree_equations(model_from_source(SourceFile("closed.lag", text))) is None


def test_closed_chain_compiles_strictly(tmp_path):
    model = model_file(closed_chain_text(8, 0.5), "closed")
    source = tmp_path / "swing.c"
    build_scene_programs(model, ("swing",), tmp_path)
    assert "lag_tree_substitute(K, pivot, response[i], 0);" in source.read_text()


# Joint dampers and forces on single joints add to the joints' torques τ_j (mechanics/trees.py).
DRIVEN = chain_text(8, seconds=3).replace("  scene swing", """  dissipation = sum(0.3*i/2*der(theta[i])^2, i in 1:n);
  force theta[2] = -0.5*sin(theta[2]) - 0.2*der(theta[2]);
  scene swing""")


def test_damped_and_forced_joints_follow_the_dense_trajectory():
    model = model_from_source(SourceFile("driven.lag", DRIVEN))
    tree = derive_tree_equations(model)
    assert isinstance(tree, TreeEquations) and not tree.conserved
    kernel, looped = run_scene(model, tree, "swing")
    assert kernel.layout.kind == "tree"
    dense = run_dense(model)
    assert dense[-1, -1] < dense[0, -1] - 1                 # the dampers take energy out
    assert_follows(looped, dense)


@pytest.mark.parametrize("old, new", [
    ("force theta[2] = -0.5*sin(theta[2])", "force theta[2] = -0.5*sin(theta[3])"),
    ("force theta[2] = -0.5*sin(theta[2])", "force theta[2] = -0.5*sin(t)"),
    ("sum(0.3*i/2*der(theta[i])^2, i in 1:n)", "sum(0.3*i/2*der(x[i])^2, i in 1:n)"),
], ids=["force on another joint", "force in time", "damper on a body"])
def test_forces_beyond_one_joint_take_the_expanded_equations(old, new):
    text = DRIVEN.replace(old, new)
    assert text != DRIVEN
    assert derive_tree_equations(model_from_source(SourceFile("driven.lag", text))) is None


@pytest.mark.slow
def test_a_long_closed_chain_projects_onto_its_pins_at_the_rounding_floor():
    """A 64-link chain pinned at both ends: its pins' residuals are sums of 64 terms, whose
    rounding puts the last Gauss-Newton corrections above a few eps of the angles. lag_project
    took that for divergence and stopped the run at t = 1.65; it now stops iterating once the
    corrections stop shrinking there, and the run keeps its energy and its pins."""
    text = closed_chain_text(64, 3).replace("rtol = 1e-12, atol = 1e-14", "rtol = 1e-8, atol = 1e-10")
    model = model_from_source(SourceFile("closed.lag", text))
    values = run_scene(model, derive_tree_equations(model), "swing")[1]
    energy, residual = values[:, 3], values[:, 5]
    assert len(values) == 61 and abs(energy[-1] - energy[0]) < 1e-7 * abs(energy[0])
    assert max(abs(residual)) < 1e-12
