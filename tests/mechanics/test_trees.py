"""The tree form (mechanics/trees.py, codegen/tree_loops.py): point masses on rigid links in
joint coordinates, solved by the articulated-body recursion in O(n).

Checked against the expanded equations (derive_equations, the dense M q'' = f, itself checked
against the textbook in test_textbook_systems.py): the same scene's trajectory from both to
1e-10, for chains of unequal masses and lengths, a branched tree and links that swing in tilted
planes (bodies in 3-D), and the energy with joint springs and constants in U; the generated code
must not grow faster than the number of links, and lag_outputs is loops over them; what the
tree form does not serve falls back to the expanded equations.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lagdsl.mechanics import derive_equations, trees
from lagdsl.mechanics.trees import TreeEquations, derive_tree_equations
from lagdsl.pipeline import execute, generate, model_from_source, plan
from lagdsl.run import toolchain
from lagdsl.scene import Overrides
from lagdsl.source import SourceFile

DENSE_64 = Path(__file__).parent / "references" / "chain_64_links_dense.csv"


def chain_text(n: int, seconds: float = 10) -> str:
    """The n-link planar chain of unequal masses and lengths (prefix sums, as in
    models/pendulum_chain.lag)."""
    return f"""model Chain
  parameter n = {n};
  parameter m[n] = {{1 + 1/i, i in 1:n}};
  parameter l[n] = {{1 - i/(3*n), i in 1:n}};
  parameter g = 9.81;
  coordinate theta[n](start = {{0.5 + 0.1*sin(i), i in 1:n}}, velocity = 0);
  let x[i] = sum(l[j]*sin(theta[j]), j in 1:i), i in 1:n;
  let y[i] = -sum(l[j]*cos(theta[j]), j in 1:i), i in 1:n;
  T = sum(m[i]/2*(der(x[i])^2 + der(y[i])^2), i in 1:n);
  U = sum(m[i]*g*y[i], i in 1:n);
  scene swing
    time(stop = {seconds}, interval = 0.05);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output theta[1], theta[n], x[n], energy;
  end swing;
end Chain;
"""


# A branched tree (two chains hang from the first bob) with torsion springs at the joints.
FORK = """model Fork
  parameter g = 9.81;  parameter k = 3;
  coordinate a[3](start = {0.4, -0.7, 1.1}, velocity = {0.2, 0, -0.3});
  let x1 = sin(a[1]);  let y1 = -cos(a[1]);
  let x2 = x1 + 0.8*sin(a[2]);  let y2 = y1 - 0.8*cos(a[2]);
  let x3 = x1 + 1.3*sin(a[3]);  let y3 = y1 - 1.3*cos(a[3]);
  T = 2/2*(der(x1)^2 + der(y1)^2) + 0.5/2*(der(x2)^2 + der(y2)^2) + 1.5/2*(der(x3)^2 + der(y3)^2);
  U = g*(2*y1 + 0.5*y2 + 1.5*y3) + k/2*a[2]^2 + k/2*(1 - cos(a[3]));
  scene swing
    time(stop = 5, interval = 0.05);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output a[1], a[2], a[3], energy;
  end swing;
end Fork;
"""

# Bodies in 3-D: link j swings in a plane tilted by alpha[j] about the x axis.
TILTED = """model Tilted
  parameter n = 4;  parameter g = 9.81;
  parameter alpha[n] = {0.3*i, i in 1:n};
  coordinate q[n](start = {0.3*i, i in 1:n}, velocity = 0.1);
  let x[i] = sum(sin(q[j]), j in 1:i), i in 1:n;
  let y[i] = -sum(cos(q[j])*cos(alpha[j]), j in 1:i), i in 1:n;
  let z[i] = sum(cos(q[j])*sin(alpha[j]), j in 1:i), i in 1:n;
  T = sum((der(x[i])^2 + der(y[i])^2 + der(z[i])^2)/2, i in 1:n);
  U = sum(g*y[i], i in 1:n);
  scene swing
    time(stop = 5, interval = 0.05);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output q[1], q[n], energy;
  end swing;
end Tilted;
"""


def trajectories(text: str, scene: str = "swing"):
    """The scene's outputs from the tree form and from the expanded equations (C backend)."""
    model = model_from_source(SourceFile("tree.lag", text))
    tree = derive_tree_equations(model)
    assert isinstance(tree, TreeEquations)
    return tree, run_tree(model, tree, scene), run_dense(model, scene)


def run_tree(model, tree: TreeEquations, scene: str = "swing") -> np.ndarray:
    kernel, values = run_scene(model, tree, scene)
    assert kernel.layout.kind == "tree"
    return values


def run_dense(model, scene: str = "swing") -> np.ndarray:
    kernel, values = run_scene(model, derive_equations(model), scene)
    assert kernel.layout is None or kernel.layout.kind != "tree"     # None: the dense LU
    return values


def run_scene(model, equations, scene: str):
    """The kernel generated for `equations` and the scene's outputs it gives (C backend)."""
    scene_plan = plan(model, equations, scene, Overrides())
    kernel, source = generate(equations, scene_plan, "c", "tree.lag")
    return kernel, execute(source, scene_plan).values


def tree_kernel(text: str):
    """The tree form of the model and its scene swing's (Kernel, C source)."""
    model = model_from_source(SourceFile("chain.lag", text))
    tree = derive_tree_equations(model)
    return tree, generate(tree, plan(model, tree, "swing", Overrides()), "c", "chain.lag")


@pytest.fixture
def small_trees(monkeypatch):
    """The tree form for a few links too (it starts at TREE_MIN_COORDINATES)."""
    monkeypatch.setattr(trees, "TREE_MIN_COORDINATES", 2)


# The chain is chaotic: rounding differences of the two solves grow with time and with n, so
# the longer chains are compared over fewer seconds. Each column agrees to 1e-10 of its size.
# The expanded equations grow as n^2 to n^3: 16 links take sympy 5 s and cc 7 s, 32 links 30 s and
# 77 s (0.9 MB of C); the 64-link chain is compared with its stored dense trajectory below.
@pytest.mark.parametrize("n, seconds", [(8, 10), pytest.param(16, 6, marks=pytest.mark.slow)])
def test_chain_of_unequal_links_follows_the_dense_trajectory(n, seconds):
    tree, looped, dense = trajectories(chain_text(n, seconds))
    assert tree.parents == (-1, *range(n - 1)) and tree.axes == 2
    assert [links.placement.count for links in tree.links] == [n]      # one shape: one loop
    assert_follows(looped, dense)


def assert_follows(looped: np.ndarray, dense: np.ndarray) -> None:
    assert looped.shape == dense.shape
    assert np.all(np.abs(looped - dense) <= 1e-10 * np.maximum(1, np.abs(dense)))


@pytest.mark.slow
def test_chain_of_64_links_follows_the_stored_dense_trajectory(update_golden, monkeypatch):
    """As above over 2 s, against the expanded equations' trajectory stored in DENSE_64: deriving
    them takes sympy minutes, and gcc -O3 takes 15-35 CPU minutes over their 4.2 MB of C.
    `--update-golden` solves them again (built at -O1: the flags change no result, see
    toolchain.LIBRARY_FLAGS, and -O1 builds in a fraction of the time, as every library of the test
    suite is built) and rewrites the file."""
    model = model_from_source(SourceFile("tree.lag", chain_text(64, 2)))
    if update_golden:
        monkeypatch.setenv(toolchain.OPTIMIZE_VARIABLE, "1")
        np.savetxt(DENSE_64, run_dense(model), fmt="%.17g", delimiter=",",
                   header="theta[1],theta[64],x[64],energy every 0.05 s: the expanded equations, dop853")
    assert DENSE_64.exists(), f"no stored trajectory {DENSE_64.name}; run pytest with --update-golden"
    tree = derive_tree_equations(model)
    assert isinstance(tree, TreeEquations) and tree.parents == (-1, *range(63))
    assert_follows(run_tree(model, tree), np.loadtxt(DENSE_64, delimiter=","))


@pytest.mark.parametrize("text, parents, axes", [(chain_text(3, seconds=5), (-1, 0, 1), 2),
                                                 (FORK, (-1, 0, 0), 2), (TILTED, (-1, 0, 1, 2), 3)])
def test_small_trees_follow_the_dense_trajectory(small_trees, text, parents, axes):
    tree, looped, dense = trajectories(text)
    assert tree.parents == parents and tree.axes == axes
    assert np.max(np.abs(looped - dense)) <= 1e-10


def test_generated_code_grows_linearly_with_the_links():
    sizes = [len(tree_kernel(chain_text(n))[1][1].text) for n in (8, 16, 32)]
    assert sizes[2] - sizes[1] <= 2.2 * (sizes[1] - sizes[0])


@pytest.mark.parametrize("text", [
    chain_text(8).replace("U = sum(m[i]*g*y[i], i in 1:n);", "U = sum(m[i]*g*y[i]^2, i in 1:n);"),
    chain_text(8).replace("T = sum(m[i]/2*", "T = der(x[1])*der(x[2]) + sum(m[i]/2*"),
    chain_text(8).replace("let y[i] = -sum(l[j]*cos(theta[j])", "let y[i] = -sum(l[j]*cos(theta[j] + theta[1])"),
], ids=["potential not linear in the positions", "kinetic term across bodies", "link term of two joints"])
def test_what_is_not_a_tree_of_point_masses_takes_the_expanded_equations(text):
    assert derive_tree_equations(model_from_source(SourceFile("chain.lag", text))) is None


# radau5's Jacobian of the expanded equations costs sympy 2 s: slow, the NumPy backend's fallback kept.
@pytest.mark.parametrize("overrides, backend", [pytest.param({"integrator": "radau5"}, "c", marks=pytest.mark.slow),
                                                ({}, "numpy")])
def test_scenes_the_tree_form_does_not_serve_fall_back(overrides, backend):
    model = model_from_source(SourceFile("chain.lag", chain_text(8, seconds=0.5)))
    tree = derive_tree_equations(model)
    scene_plan = plan(model, tree, "swing", Overrides(**overrides))
    kernel, _ = generate(tree, scene_plan, backend, "chain.lag")
    assert kernel.layout is None or kernel.layout.kind != "tree"


# Joint springs (V_j) and constants in U (U_0 = 2n + 5): every part of h that the links' loops add.
SPRUNG = chain_text(8, seconds=1).replace(
    "U = sum(m[i]*g*y[i], i in 1:n);", "U = sum(m[i]*g*y[i] + 2*(1 - cos(theta[i])), i in 1:n) + 5;")


def test_energy_from_the_links_loops_equals_the_dense_energy():
    tree, looped, dense = trajectories(SPRUNG)
    assert tree.energy_shift == 21
    energy = -1
    assert abs(looped[0, energy] - dense[0, energy]) <= 1e-13 * abs(dense[0, energy])     # the same state
    assert np.all(np.abs(looped - dense) <= 1e-10 * np.maximum(1, np.abs(dense)))


def test_the_outputs_are_loops_over_the_links():
    """lag_outputs reads the energy and x[n] from loops and a sweep: its statements do not grow
    with n."""
    statements = []
    for n in (8, 32):
        _, (kernel, source) = tree_kernel(chain_text(n))
        outputs = kernel.outputs
        assert outputs.path_sums is not None and len(outputs.loops) == 2
        assert all(loop.count == n for loop in outputs.loops)
        statements.append(len(outputs.inputs) + len(outputs.assignments) + len(outputs.stores))
        body = source.text.split("static int lag_outputs(")[1].split("\n}\n")[0]
        assert f"for (int i = 0; i < {n}; ++i)" in body and "lag_parent[j]" in body
    assert statements[0] == statements[1]
