"""Extremes of a Chebyshev series over boxes (:mod:`fuzzymbs.fuzzy.box_search`)."""

from __future__ import annotations

import numpy as np

from fuzzymbs.fuzzy import box_search
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient, basis_matrix
from fuzzymbs.fuzzy.residual_correction import KernelCorrection

RNG = np.random.default_rng(7)
DEGREES = np.array([(a, b) for a in range(4) for b in range(4)], dtype=np.int64)


def _plain_polish(degrees, coefficients, starts, element, sign, low, high, correction):
    """The search with every start kept for all its steps (the second method)."""
    x = starts.copy()
    width = high - low
    step = 0.05 * np.maximum(width.max(axis=1), 1e-300)
    column = coefficients[:, element]

    def value_at(points):
        own = np.einsum("kd,dk->k", basis_matrix(degrees, points), column)
        return own if correction is None else own + correction.at(points, element)

    value = value_at(x)
    for _ in range(box_search._STEPS):
        _, gradient = basis_gradient(degrees, x)
        slope = np.einsum("ikd,dk->ki", gradient, column)
        if correction is not None:
            slope = slope + correction.gradient_at(x, element)
        slope = np.where(width > 0.0, slope * sign[:, None], 0.0)
        norm = np.linalg.norm(slope, axis=1)
        moving = norm > 0.0
        direction = np.where(moving[:, None], slope / np.where(moving, norm, 1.0)[:, None], 0.0)
        trial = np.clip(x + step[:, None] * direction, low, high)
        trial_value = value_at(trial)
        better = sign * trial_value > sign * value
        x[better], value[better] = trial[better], trial_value[better]
        step = np.where(better, 1.5 * step, 0.5 * step)
    return x, value


def test_the_search_drops_only_starts_that_cannot_move():
    # against the plain search that keeps every start for all its steps: bit for bit
    # the same points and values, with a kernel correction, corner and interior starts
    # and a box of zero width in one direction
    elements = 30
    coefficients = RNG.normal(size=(len(DEGREES), elements))
    coefficients[1:4, :10] *= 50.0  # the first 10 elements nearly linear in x_2
    centres = RNG.uniform(-1, 1, size=(12, 2))
    correction = KernelCorrection(centres, RNG.normal(size=(12, elements)), np.ones(2, bool))
    count = 400
    element = RNG.integers(0, elements, size=count)
    sign = RNG.choice([-1.0, 1.0], size=count)
    low = np.tile([-1.0, -0.5], (count, 1))
    high = np.tile([1.0, 0.5], (count, 1))
    high[:50, 1] = low[:50, 1]  # no width in x_2
    starts = RNG.uniform(low, high)
    starts[::3] = np.where(RNG.random((len(starts[::3]), 2)) < 0.5, low[::3], high[::3])
    for fix in (None, correction):
        found, value = box_search.climb(
            DEGREES, coefficients, starts, element, sign, low, high, fix
        )
        plain_found, plain_value = _plain_polish(
            DEGREES, coefficients, starts, element, sign, low, high, fix
        )
        np.testing.assert_array_equal(found, plain_found)
        np.testing.assert_array_equal(value, plain_value)


def test_box_extremes_against_a_dense_grid():
    # second method: the series on a 401 x 401 grid of each box; the search finds
    # extremes at least as good, and no more than the grid's resolution better
    coefficients = RNG.normal(size=(len(DEGREES), 5))
    low = np.array([[-1.0, -1.0], [-0.4, -0.2]])
    high = np.array([[1.0, 1.0], [0.4, 0.6]])
    lower, upper, arg_lower, arg_upper = box_search.box_extremes(DEGREES, coefficients, low, high)
    for j in range(len(low)):
        axes = [np.linspace(low[j, i], high[j, i], 401) for i in range(2)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
        values = basis_matrix(DEGREES, grid) @ coefficients
        assert np.all(lower[j] <= values.min(axis=0) + 1e-12)
        assert np.all(upper[j] >= values.max(axis=0) - 1e-12)
        # a 401-point grid of a cubic misses an extremum by at most ~1e-4 of its range
        span = values.max(axis=0) - values.min(axis=0)
        assert np.all(values.min(axis=0) - lower[j] <= 1e-4 * span)
        assert np.all(upper[j] - values.max(axis=0) <= 1e-4 * span)
        at_lower = basis_matrix(DEGREES, arg_lower[j]) * coefficients.T
        np.testing.assert_allclose(at_lower.sum(axis=1), lower[j], rtol=0, atol=1e-12)
        assert np.all((arg_upper[j] >= low[j]) & (arg_upper[j] <= high[j]))
