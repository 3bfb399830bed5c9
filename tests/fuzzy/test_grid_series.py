"""A Chebyshev series on a tensor grid by sum factorisation
(:mod:`fuzzymbs.fuzzy.grid_series`) against the term-by-term evaluation at every point."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.fuzzy import box_search
from fuzzymbs.fuzzy.chebyshev_grid import evaluate_series
from fuzzymbs.fuzzy.grid_series import GridSeries
from fuzzymbs.fuzzy.grids import cartesian
from fuzzymbs.fuzzy.residual_correction import KernelCorrection


@pytest.mark.parametrize("dimension", [1, 2, 3, 4])
def test_values_on_the_grid_equal_the_series_at_its_points(dimension):
    # second method: evaluate_series, the basis of every term at every grid point; the sums
    # run in another order, so they agree to round-off (1e-14 of the largest value)
    rng = np.random.default_rng(dimension)
    degrees = np.unique(rng.integers(0, 9, (80, dimension)), axis=0)
    coefficients = rng.normal(size=(len(degrees), 3))
    axes = [np.sort(rng.uniform(-1.0, 1.0, 7)) for _ in range(dimension)]
    axes[-1] = axes[-1][:1] if dimension > 1 else axes[-1]  # a frozen direction: one value
    series = GridSeries(degrees, coefficients, axes)
    expected = evaluate_series(degrees, coefficients, cartesian(axes))
    for slab in (1, 3, 7):
        values = np.concatenate(
            [series.values(slice(first, first + slab)) for first in range(0, 7, slab)]
        )
        assert values.shape == expected.shape
        np.testing.assert_allclose(values, expected, rtol=0, atol=1e-14 * np.abs(expected).max())
    assert series.inner == len(expected) // 7


def test_a_constant_series_and_mismatched_degrees():
    series = GridSeries(np.zeros((1, 2), np.int64), np.array([[2.5]]), [np.zeros(3), np.ones(2)])
    assert np.all(series.values(slice(0, 3)) == 2.5)
    with pytest.raises(ValueError, match="grid axes"):
        GridSeries(np.zeros((1, 2), np.int64), np.ones((1, 1)), [np.zeros(3)])
    # a series without terms is zero (the box search keeps the term-by-term path for it)
    box = np.array([[-1.0, -1.0]]), np.array([[1.0, 1.0]])
    lower, upper, _, _ = box_search.box_extremes(np.zeros((0, 2), np.int64), np.zeros((0, 3)), *box)
    assert np.all(lower == 0.0) and np.all(upper == 0.0)


def test_box_extremes_take_the_same_grid_values_either_way(monkeypatch):
    # the box search sums the grid one direction at a time when its sums are small; with
    # the threshold at zero it takes the term-by-term path: the same bounds to round-off
    rng = np.random.default_rng(5)
    degrees = np.array([(a, b, c) for a in range(5) for b in range(5 - a) for c in range(3)])
    coefficients = rng.normal(size=(len(degrees), 4)) / (1.0 + degrees.sum(axis=1))[:, None]
    centres = rng.uniform(-1.0, 1.0, (12, 3))
    correction = KernelCorrection(centres, rng.normal(size=(12, 4)) * 0.01, np.ones(3, bool))
    low = np.array([[-1.0, -1.0, -1.0], [-0.3, -0.5, 0.2]])
    high = np.array([[1.0, 1.0, 1.0], [0.3, 0.1, 0.2]])
    factored = box_search.box_extremes(degrees, coefficients, low, high, correction=correction)
    monkeypatch.setattr(box_search, "_BLOCK_ELEMENTS", 0)
    termwise = box_search.box_extremes(degrees, coefficients, low, high, correction=correction)
    for a, b in zip(factored, termwise, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
