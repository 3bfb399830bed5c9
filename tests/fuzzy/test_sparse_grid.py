"""Smolyak sparse grid on Clenshaw-Curtis nodes: counts, exactness, convergence, interpolation."""

import itertools

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, sparse_grid


def brute_force_nodes(n: int, level: int) -> set[tuple[float, ...]]:
    """Union of all tensor grids X^i1 x ... x X^in with |i| <= n + level (independent code).

    1-D nodes straight from the textbook formula (1 - cos(pi k / (m - 1))) / 2,
    m = 1 (midpoint) or 2^(i-1) + 1, rounded to 12 digits to merge shared nodes.
    """

    def nodes_1d(i: int) -> list[float]:
        if i == 1:
            return [0.5]
        m = 2 ** (i - 1) + 1
        return [round((1 - np.cos(np.pi * k / (m - 1))) / 2, 12) for k in range(m)]

    union: set[tuple[float, ...]] = set()
    for index in itertools.product(range(1, level + 2), repeat=n):
        if sum(index) <= n + level:
            union.update(itertools.product(*(nodes_1d(i) for i in index)))
    return union


# Counts of the Clenshaw-Curtis Smolyak grid for q = n, n+1, ...: 1, 5, 13, 29, 65 (n = 2) and
# 1, 7, 25, 69, 177 (n = 3) as recalled from the literature (e.g. J. Burkardt, "Counting
# abscissas in sparse grids", 2014; the 1-D convention 1, 3, 5, 9, 17 is that of his
# SPARSE_GRID_CC); the multi-dimensional tables were not found to check, so the test also
# derives every count independently by the brute-force union above.
@pytest.mark.parametrize(
    ("n", "counts"), [(1, [1, 3, 5, 9, 17]), (2, [1, 5, 13, 29, 65]), (3, [1, 7, 25, 69, 177])]
)
def test_node_counts_match_published_and_brute_force(n, counts):
    for level, expected in enumerate(counts):
        nodes = sparse_grid(n, level)
        assert nodes.shape == (expected, n)
        assert len(brute_force_nodes(n, level)) == expected
        rounded = {tuple(round(float(v), 12) for v in row) for row in nodes}
        assert rounded == brute_force_nodes(n, level)


def test_nodes_are_unique_in_unit_cube_and_deterministic():
    nodes = sparse_grid(4, 3)
    assert len({tuple(row) for row in nodes.tolist()}) == len(nodes)
    assert nodes.min() == 0.0 and nodes.max() == 1.0
    np.testing.assert_array_equal(nodes[0], 0.5)  # the midpoint comes first
    np.testing.assert_array_equal(nodes, sparse_grid(4, 3))


def test_nodes_are_nested_across_levels():
    coarse = {tuple(row) for row in sparse_grid(3, 2).tolist()}
    fine = {tuple(row) for row in sparse_grid(3, 3).tolist()}
    assert coarse <= fine  # bit-identical shared nodes


def test_combination_coefficients_sum_to_one():
    # A(q, n) reproduces constants: the coefficients sum to 1 (Barthelmann et al. 2000)
    for n, level in [(1, 3), (2, 4), (3, 3), (5, 2)]:
        assert sum(c for _, c in SparseGrid(n, level).terms) == pytest.approx(1.0, abs=1e-14)


def polynomial(points, degree):
    """A dense polynomial of total degree ``degree`` in 3 variables (all monomials present)."""
    x = np.atleast_2d(points)
    total = np.zeros(len(x))
    for powers in itertools.product(range(degree + 1), repeat=3):
        if sum(powers) <= degree:
            coefficient = 1.0 + 0.1 * (powers[0] + 2 * powers[1] + 3 * powers[2])
            total += coefficient * np.prod(x ** np.array(powers), axis=1)
    return total


@pytest.mark.parametrize("degree", [2, 3])
def test_exact_for_total_degree_up_to_level(degree):
    # closed form: A(n + k, n) reproduces every polynomial of total degree <= k
    grid = SparseGrid(3, degree)
    points = np.random.default_rng(1).random((200, 3))
    interpolated = grid.interpolate(points, polynomial(grid.nodes, degree))
    np.testing.assert_allclose(interpolated, polynomial(points, degree), rtol=0, atol=1e-12)


def test_not_exact_one_level_too_low():
    # x1 x2 x3 needs i = (2, 2, 2), |i| - n = 3: level 2 cannot reproduce it
    grid = SparseGrid(3, 2)
    points = np.random.default_rng(2).random((200, 3))
    error = grid.interpolate(points, np.prod(grid.nodes, axis=1)) - np.prod(points, axis=1)
    assert np.abs(error).max() > 1e-2


def test_one_dimensional_interpolant_is_the_polynomial_through_the_nodes():
    # independent reference: NumPy's least-squares fit of degree m-1 through m nodes interpolates
    grid = SparseGrid(1, 3)  # 9 Clenshaw-Curtis nodes
    values = np.exp(np.sin(3 * grid.nodes[:, 0]))
    fit = np.polynomial.Polynomial.fit(grid.nodes[:, 0], values, deg=len(grid) - 1)
    x = np.linspace(0, 1, 101)
    np.testing.assert_allclose(grid.interpolate(x[:, None], values), fit(x), atol=1e-10)


def test_error_decreases_with_level_for_smooth_function():
    def smooth(x):
        return np.exp(0.7 * x[:, 0]) * np.cos(x[:, 1] + 0.5 * x[:, 2]) + x[:, 3] ** 2 / (
            1 + x[:, 0]
        )

    points = np.random.default_rng(3).random((2000, 4))
    errors = []
    for level in range(1, 6):
        grid = SparseGrid(4, level)
        interpolated = grid.interpolate(points, smooth(grid.nodes))
        errors.append(np.abs(interpolated - smooth(points)).max())
    # measured (9, 41, 137, 401, 1105 nodes): 4.2e-1, 5.1e-2, 9.3e-4, 5.5e-6, 2.8e-8
    assert all(b < a for a, b in itertools.pairwise(errors))
    assert errors[-1] < 1e-6


def test_weights_at_nodes_are_unit_vectors():
    grid = SparseGrid(3, 3)
    np.testing.assert_allclose(grid.weights(grid.nodes), np.eye(len(grid)), rtol=0, atol=1e-12)
    values = np.random.default_rng(4).normal(size=len(grid))
    np.testing.assert_allclose(grid.interpolate(grid.nodes, values), values, atol=1e-12)


def test_trailing_shape_and_blocks_match_elementwise():
    grid = SparseGrid(2, 3)
    rng = np.random.default_rng(5)
    values = rng.normal(size=(len(grid), 4, 3))
    points = rng.random((37, 2))
    result = grid.interpolate(points, values)
    assert result.shape == (37, 4, 3)
    weights = grid.weights(points)
    np.testing.assert_allclose(result, np.einsum("pn,nab->pab", weights, values), atol=1e-13)


@pytest.mark.parametrize(
    ("dimension", "level"), [(0, 2), (2, -1), (True, 2), (2, 1.5), (2.0, 1), ("2", 1)]
)
def test_bad_dimension_or_level_raises(dimension, level):
    with pytest.raises(InvalidParameterError, match="must be an int"):
        SparseGrid(dimension, level)


def test_bad_points_or_values_raise():
    grid = SparseGrid(2, 2)
    values = np.zeros(len(grid))
    with pytest.raises(InvalidParameterError, match="shape"):
        grid.interpolate(np.zeros((3, 3)), values)
    with pytest.raises(InvalidParameterError, match="unit cube"):
        grid.interpolate([[0.5, 1.5]], values)
    with pytest.raises(InvalidParameterError, match="finite"):
        grid.interpolate([[0.5, np.nan]], values)
    with pytest.raises(InvalidParameterError, match="leading axis"):
        grid.interpolate([[0.5, 0.5]], np.zeros(len(grid) + 1))
