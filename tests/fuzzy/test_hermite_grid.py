"""The sparse grid's Hermite direction (fuzzymbs.fuzzy.chebyshev_grid.use_hermite)."""

import numpy as np
import pytest

from fuzzymbs.fuzzy.chebyshev_grid import (
    ChebyshevSparseGrid,
    basis_gradient,
    evaluate_series,
    node_values,
)


def _grid(function, gradient, indices, dimension=2):
    """A grid over ``indices`` with the function's values and gradients at its nodes."""
    grid = ChebyshevSparseGrid(dimension)
    for index in indices:
        new = grid.add_index(index)
        x = node_values(np.array(new))
        grid.set_values(new, function(x)[:, None], gradient(x)[:, None, :])
    return grid


def _poly(x):
    return x[:, 0] ** 5 * x[:, 1] + x[:, 1] ** 2 - 0.5 * x[:, 0] ** 4


def _poly_gradient(x):
    dx = 5 * x[:, 0] ** 4 * x[:, 1] - 2 * x[:, 0] ** 3
    return np.stack((dx, x[:, 0] ** 5 + 2 * x[:, 1]), axis=1)


SQUARE = [(0, 0), (1, 0), (0, 1), (1, 1)]


def test_a_hermite_direction_reproduces_twice_the_degree():
    # level 1 holds 3 nodes: the Hermite interpolant along x has degree 5 (values and
    # derivatives, 6 conditions), along y the values' degree 2; so the set {0, 1}^2 holds
    # x^5 y + y^2 - x^4 / 2 exactly with Hermite along x, and not with values only
    grid = _grid(_poly, _poly_gradient, SQUARE)
    points = np.random.default_rng(2).uniform(-1, 1, (300, 2))
    grid.use_hermite(None)
    plain = evaluate_series(*grid.series(), points)[:, 0]
    assert np.abs(plain - _poly(points)).max() > 0.1
    grid.use_hermite(0)
    degrees, _ = grid.series()
    assert degrees[:, 0].max() == 5 and degrees[:, 1].max() == 2
    hermite = evaluate_series(*grid.series(), points)[:, 0]
    np.testing.assert_allclose(hermite, _poly(points), atol=1e-12)


def test_the_hermite_grid_takes_its_nodes_values_and_derivatives():
    # a function no finite series holds: interpolation of the values at every node and of
    # the derivative along the Hermite direction, to round-off
    def function(x):
        return np.exp(np.sin(3 * x[:, 0]) + x[:, 1] * x[:, 2]) + x[:, 1]

    def gradient(x):
        f = np.exp(np.sin(3 * x[:, 0]) + x[:, 1] * x[:, 2])
        return np.stack((3 * np.cos(3 * x[:, 0]) * f, x[:, 2] * f + 1, x[:, 1] * f), axis=1)

    indices = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (2, 0, 0), (1, 1, 0), (3, 0, 0)]
    grid = _grid(function, gradient, indices, dimension=3)
    grid.use_hermite(0)
    nodes = sorted({q for index in indices for q in grid.new_nodes(index)})
    x = node_values(np.array(nodes))
    degrees, coefficients = grid.series()
    basis, slope = basis_gradient(degrees, x)
    np.testing.assert_allclose(basis @ coefficients[:, 0], function(x), atol=1e-11)
    np.testing.assert_allclose(slope[0] @ coefficients[:, 0], gradient(x)[:, 0], atol=1e-9)
    # along the other directions the derivatives are not interpolated
    assert np.abs(slope[1] @ coefficients[:, 0] - gradient(x)[:, 1]).max() > 1e-3


def test_a_hermite_direction_needs_every_nodes_derivatives():
    grid = ChebyshevSparseGrid(2)
    new = grid.add_index((0, 0))
    grid.set_values(new, np.ones((1, 1)))
    assert not grid.has_slopes()
    with pytest.raises(ValueError, match="derivatives at every node"):
        grid.use_hermite(0)
    grid.use_hermite(None)  # values only: always possible
    full = _grid(_poly, _poly_gradient, SQUARE)
    assert full.has_slopes()
    with pytest.raises(ValueError, match="direction 2"):
        full.use_hermite(2)
