"""The structure of the mass matrix found at generation time, and the factorisations written for it."""
from __future__ import annotations

import numpy as np
import pytest
import sympy

import lagdsl
from lagdsl.codegen.c_factor import factorisation_text
from lagdsl.codegen.structure import JacobianLayout, MassLayout, jacobian_layout, kkt_layout, mass_layout
from lagdsl.settings import Overrides
from tests.conftest import library_model, model_file

a, b, c = sympy.symbols("a b c", positive=True)


def pattern(rows: list[str]) -> tuple[tuple[sympy.Expr, ...], ...]:
    """A symmetric matrix of symbols from a picture: 'x' is a nonzero entry, '.' a zero."""
    return tuple(tuple(sympy.Symbol(f"m{i}{j}") if ch == "x" else sympy.S.Zero for j, ch in enumerate(row))
                 for i, row in enumerate(rows))


def test_a_diagonal_mass_matrix_is_divided_by():
    layout = mass_layout(((a, 0, 0), (0, b, 0), (0, 0, c)))
    assert layout.kind == "diagonal" and layout.size == 3
    assert [layout.coordinate_slot(k, k) for k in range(3)] == [0, 1, 2]


def test_a_tridiagonal_mass_matrix_is_factored_without_fill():
    layout = mass_layout(pattern(["xx...", "xxx..", ".xxx.", "..xxx", "...xx"]))
    assert layout.kind == "sparse"
    assert layout.size == 5 + 4            # the pivots and the 4 subdiagonal entries: no fill


def test_minimum_degree_eliminates_the_hub_of_an_arrow_late():
    # a cart (coordinate 0) carrying four independent pendulums: M is an arrow
    layout = mass_layout(pattern(["xxxxx", "xx...", "x.x..", "x..x.", "x...x"]))
    assert 0 not in layout.order[:3]       # (the last two tie, and go by index)
    assert layout.size == 5 + 4            # eliminated first, the hub would fill the whole matrix


def test_small_dense_matrices_are_straight_line_and_large_ones_loop():
    assert mass_layout(pattern(["xxxx"] * 4)).kind == "sparse"
    assert mass_layout(pattern(["xxxxx"] * 5)).kind == "dense"


def cartesian_chain(links: int) -> tuple[tuple, list[tuple]]:
    """M (diagonal) and the rows of A of a planar chain in Cartesian coordinates (x_1..x_n,
    y_1..y_n): link i joins bob i - 1 (or the pivot) and bob i."""
    n = 2 * links
    mass = tuple(tuple(a if j == k else sympy.S.Zero for j in range(n)) for k in range(n))
    rows = []
    for i in range(links):
        touched = {i, links + i} | ({i - 1, links + i - 1} if i else set())
        rows.append(tuple(sympy.Symbol(f"A{i}_{j}") if j in touched else sympy.S.Zero for j in range(n)))
    return mass, rows


def test_a_large_saddle_point_system_is_factored_sparse_with_the_multipliers_last():
    mass, rows = cartesian_chain(8)
    layout = kkt_layout(mass, rows)
    assert layout is not None and (layout.n, layout.coordinates, layout.multipliers) == (24, 16, 8)
    assert sorted(layout.order[16:]) == list(range(16, 24))    # every multiplier after the coordinates
    assert layout.size <= 24 + 2 * 32      # the pivots, A's 30 entries, the multipliers' tridiagonal fill
    assert kkt_layout(*cartesian_chain(2)) is None             # 6 unknowns: the dense LU


def test_the_library_solves_a_chain_in_cartesian_coordinates_by_the_sparse_ldlt():
    text = library_model("cartesian_chain").emit("c").text
    assert "static const int lag_pivots[LAG_NK]" in text and "lag_lu_rcond" not in text
    assert "lag_lu_rcond" in library_model("andrews").emit("c").text     # 13 unknowns: LU


def test_the_projection_forms_only_the_nonzero_entries_of_its_gram_matrix():
    """G = A Aᵀ of the projection onto the constraints: link i of a chain involves bobs i - 1 and
    i, so A has 2 or 4 columns a row and G is tridiagonal: 8 + 7 of its 64 entries are formed."""
    text = library_model("cartesian_chain").emit("c").text
    assert "static const int lag_a_start[LAG_NC + 1] = { 0, 2, 6, 10, 14, 18, 22, 26, 30 };" in text
    assert "#define LAG_GRAM_PAIRS 15" in text
    assert "{ 0, 0 }, { 1, 0 }, { 1, 1 }, { 2, 1 }" in text


def random_matrix(layout_pattern: list[str], seed: int) -> np.ndarray:
    """A symmetric positive definite matrix with the given pattern (diagonally dominant)."""
    generator = np.random.default_rng(seed)
    mask = np.array([[ch == "x" for ch in row] for row in layout_pattern])
    values = generator.uniform(-1, 1, mask.shape) * mask
    values = (values + values.T) / 2
    return values + np.diag(np.abs(values).sum(axis=1) + generator.uniform(0.5, 2, len(mask)))


def run_factorisation(layout: MassLayout, matrix: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, float]:
    """Execute the generated straight-line statements (C that is also Python, line by line)."""
    text = factorisation_text(layout)
    K = np.zeros(layout.size)
    for (k, j) in [(k, j) for k in range(layout.n) for j in range(k + 1)]:
        if matrix[k, j] != 0:
            K[layout.coordinate_slot(k, j)] = matrix[k, j]
    scale = 1 / np.sqrt(K[[layout.slots[(p, p)] for p in range(layout.n)]])
    namespace = {"K": K, "scale": scale}
    for line in text["scale"] + text["columns"]:
        if not line.startswith("if"):
            exec(line.rstrip(";"), namespace)          # noqa: S102 (our own generated statements)
    pivots = K[[layout.slots[(p, p)] for p in range(layout.n)]]
    x = np.array([rhs[k] for k in layout.order]) * scale
    namespace["x"] = x
    for line in text["forward"]:
        exec(line.rstrip(";"), namespace)             # noqa: S102
    x /= pivots
    for line in text["backward"]:
        exec(line.rstrip(";"), namespace)             # noqa: S102
    solution = np.empty(layout.n)
    solution[list(layout.order)] = x * scale
    return solution, pivots.min() / pivots.max()


@pytest.mark.parametrize("picture", [
    ["xx...", "xxx..", ".xxx.", "..xxx", "...xx"],
    ["xxxxx", "xx...", "x.x..", "x..x.", "x...x"],
    ["xx.x.", "xxx..", ".xx.x", "x..xx", "..xxx"],          # a cycle: minimum degree must fill
    ["xxx", "xxx", "xxx"],
])
def test_the_straight_line_ldlt_solves_the_system(picture):
    layout = mass_layout(pattern(picture))
    assert layout.kind == "sparse"
    matrix = random_matrix(picture, seed=len(picture) + picture[0].count("x"))
    rhs = np.arange(1.0, layout.n + 1)
    solution, rcond = run_factorisation(layout, matrix, rhs)
    assert np.allclose(matrix @ solution, rhs, rtol=1e-13, atol=1e-13)
    scaled = matrix / np.sqrt(np.outer(np.diag(matrix), np.diag(matrix)))
    assert rcond >= 1 / np.linalg.cond(scaled, 2) * (1 - 1e-12)     # never below the true 1/cond


def test_fem_string_mass_matrix_is_banded_and_fpu_chain_is_diagonal():
    assert library_model("fem_string").emit("c").text.count("lag_order[LAG_NK]") == 1
    fpu = library_model("fermi_pasta_ulam")
    text = fpu.emit("c").text
    assert "b[i] *= K[i];" in text and "lag_cholesky_factor" not in text
    assert "K = numpy.zeros((NK,) + shape)" in fpu.emit("numpy").text


def test_a_constant_mass_matrix_is_factored_once_per_run_with_the_runs_parameters():
    """M = diag(m, 2 m) depends on a parameter only: lag_system_prepare factors it before the
    first step, so the run must see the m it was given (x = cos(sqrt(k/m) t), y = cos(sqrt(k/2m) t))."""
    model = model_file("model Springs\n  parameter m = 1.0;\n  parameter k = 1.0;\n  coordinate x(start = 1);\n"
                       "  coordinate y(start = 1);\n  T = m/2*der(x)^2 + m*der(y)^2;\n  U = k/2*(x^2 + y^2);\n"
                       "  scene s\n    time(stop = 3, interval = 1);\n    integrator dop853(rtol = 1e-12, atol = 1e-12);\n"
                       "    output x, y;\n  end s;\nend Springs;\n", "springs")
    loaded = lagdsl.load(model)
    text = loaded.emit("c").text
    accelerations = text[text.index("static int lag_accelerations"):text.index("/* dy/dt")]
    assert "lag_assemble_mass(sys->par, sys->mass)" in text and "lag_factor" not in accelerations
    for backend in ("c", "numpy"):
        result = loaded.simulate(backend=backend, m=4.0, k=9.0)
        assert np.allclose(result["x"], np.cos(1.5 * result.t), atol=1e-9)
        assert np.allclose(result["y"], np.cos(np.sqrt(9 / 8) * result.t), atol=1e-9)


def test_a_mass_matrix_that_varies_is_factored_at_every_evaluation():
    text = library_model("double_pendulum").emit("c").text
    assert "lag_assemble_mass" not in text and "lag_solve(LAG_NK, K, b, &rcond)" in text


def test_a_diagonal_mass_matrix_that_is_not_positive_is_singular():
    model = model_file("model Negative\n  parameter m = 1.0;\n  coordinate x(start = 1);\n"
                       "  coordinate y;\n  T = m/2*der(x)^2 + der(y)^2/2;\n  U = x^2/2 + y^2/2;\n"
                       "  scene s\n    time(stop = 1, interval = 0.5);\n  end s;\nend Negative;\n", "negative")
    for backend in ("c", "numpy"):
        with pytest.raises(lagdsl.SimulationError, match="singular"):
            lagdsl.load(model).simulate(backend=backend, m=-1.0)


@pytest.mark.slow
def test_the_newton_matrices_of_radau5_are_banded_for_a_chain_and_dense_otherwise():
    """E(g) = [g Dz + Dv + Dq/g | Dz_λ] has the pattern of M and of the forces' reach (radau5.c)."""
    assert jacobian_layout(200, False, {(1, 0), (0, 1)}) == JacobianLayout("banded", 200, 1, 1)
    assert jacobian_layout(8, False, {(1, 0), (0, 1)}).kind == "dense"        # a band would not pay
    assert jacobian_layout(200, True, {(1, 0), (0, 1)}) == JacobianLayout("dense", 200, 199, 199)
    band = JacobianLayout("banded", 10, 2, 1)
    assert [band.slot(4, c) for c in (2, 3, 4, 5)] == [16, 17, 18, 19] and band.size == 40
    implicit = Overrides(integrator="radau5")
    fpu = library_model("fpu_chain").emit("c", scene="implicit").text
    assert "#define LAG_JAC_LOWER 1\n#define LAG_JAC_UPPER 1\n#define LAG_JAC_SIZE 600" in fpu
    assert "for (int i = 0; i < 100; ++i)" in fpu                # Dq from the stiff springs' loop
    chain = library_model("pendulum_chain").emit("c", overrides=implicit).text
    assert "#define LAG_JAC_AT(r, c) ((r) * LAG_NK + (c))" in chain and "#define LAG_JAC_LOWER 11" in chain
    penny = library_model("rolling_penny").emit("c", overrides=implicit).text
    assert "#define LAG_NK 6" in penny and "#define LAG_JAC_SIZE 36" in penny     # 4 coordinates, 2 constraints
