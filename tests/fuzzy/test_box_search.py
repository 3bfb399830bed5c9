"""Extremes of a Chebyshev series over boxes (:mod:`fuzzymbs.fuzzy.box_search`)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from fuzzymbs.fuzzy import box_search
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient, basis_matrix
from fuzzymbs.fuzzy.hermite_correction import HermiteCorrection
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


def test_the_compiled_search_against_the_array_search():
    # second method: the same ascent written with arrays, every start kept for all its
    # steps (_plain_polish); the compiled one sums the same terms in another order, so
    # the two agree to round-off, not bit for bit. Tolerances: values to 1e-12 of their
    # spread (round-off of sums of ~50 terms of order 1-50), points to 1e-4 (near a
    # smooth extremum a 1e-13 change of value moves the best point by up to ~1e-6, and
    # the step rule can end a few of its halvings apart); with the value-only and the
    # gradient-enhanced correction (and each without x_2), corner and interior starts and
    # a box of zero width in one direction (a start whose slope points out of its box
    # stops at once)
    elements = 30
    coefficients = RNG.normal(size=(len(DEGREES), elements))
    coefficients[1:4, :10] *= 50.0  # the first 10 elements nearly linear in x_2
    centres = RNG.uniform(-1, 1, size=(12, 2))
    residuals = RNG.normal(size=(12, elements))
    correction = KernelCorrection(centres, residuals, np.ones(2, bool))
    slopes = RNG.normal(size=(12, elements, 2))
    sloped = np.arange(12) % 3 != 0
    hermite = HermiteCorrection(centres, residuals, slopes, sloped, np.ones(2, bool))
    count = 400
    element = RNG.integers(0, elements, size=count)
    sign = RNG.choice([-1.0, 1.0], size=count)
    low = np.tile([-1.0, -0.5], (count, 1))
    high = np.tile([1.0, 0.5], (count, 1))
    high[:50, 1] = low[:50, 1]  # no width in x_2
    starts = RNG.uniform(low, high)
    starts[::3] = np.where(RNG.random((len(starts[::3]), 2)) < 0.5, low[::3], high[::3])
    # a correction built without x_2 (a parameter of zero width: every box is flat in it),
    # through runs spread along x_1 (random ones crowd there, and the interpolant's
    # weights grow to 1e5, their round-off with them)
    flat = np.array([True, False])
    spread_centres = np.column_stack((np.linspace(-0.9, 0.9, 12), centres[:, 1]))
    flat_correction = KernelCorrection(spread_centres, residuals, flat)
    flat_hermite = HermiteCorrection(spread_centres, residuals, slopes, sloped, flat)
    for fix in (None, correction, hermite, flat_correction, flat_hermite):
        if fix is not None and not fix.moving.all():
            low[:, 1] = high[:, 1] = starts[:, 1] = 0.1
        found, value = box_search.climb(
            DEGREES, coefficients, starts, element, sign, low, high, fix
        )
        plain_found, plain_value = _plain_polish(
            DEGREES, coefficients, starts, element, sign, low, high, fix
        )
        spread = np.ptp(plain_value)
        np.testing.assert_allclose(value, plain_value, rtol=0, atol=1e-12 * spread)
        np.testing.assert_allclose(found, plain_found, rtol=0, atol=1e-4)
        assert np.all(found[:50, 1] == low[:50, 1])  # never off a face of zero width
        assert np.all((found >= low) & (found <= high))
        # the value reported is the surrogate's at the point reported
        own = box_search.values_at(DEGREES, coefficients, found, element, fix)
        np.testing.assert_allclose(value, own, rtol=0, atol=1e-12 * spread)


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


def test_the_search_gives_the_same_numbers_on_any_number_of_threads(monkeypatch):
    # each start climbs on its own: split over threads (every t-th start to a thread) the
    # points and values are bit for bit those of one thread
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one thread only")
    elements = 12
    coefficients = RNG.normal(size=(len(DEGREES), elements))
    centres = RNG.uniform(-1, 1, size=(9, 2))
    correction = KernelCorrection(centres, RNG.normal(size=(9, elements)), np.ones(2, bool))
    count = 301
    element = RNG.integers(0, elements, size=count)
    sign = RNG.choice([-1.0, 1.0], size=count)
    low, high = np.tile([-1.0, -0.5], (count, 1)), np.tile([1.0, 0.5], (count, 1))
    starts = RNG.uniform(low, high)
    arguments = (DEGREES, coefficients, starts, element, sign, low, high, correction)
    one = box_search.climb(*arguments)  # 301 starts: below one thread's share
    monkeypatch.setattr(box_search, "_STARTS_PER_THREAD", 10)
    previous = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        two = box_search.climb(*arguments)
    finally:
        numba.set_num_threads(previous)
    np.testing.assert_array_equal(two[0], one[0])
    np.testing.assert_array_equal(two[1], one[1])


def test_importing_the_fuzzy_engine_does_not_load_numba(fresh_python):
    # the compiled climb is imported when a search first climbs: a user of the fuzzy
    # engine alone (plans, arithmetic) does not pay Numba's import (0.18 s measured)
    code = "import sys, fuzzymbs.fuzzy; print('numba' in sys.modules)"
    assert fresh_python(code).strip() == "False"
    # nor does the adaptive method load SciPy's linear algebra (0.25 s) before a correction
    # with gradients is solved (fuzzymbs.fuzzy.bordered_system imports it then)
    code = "import sys, fuzzymbs.fuzzy.adaptive; print('scipy.linalg' in sys.modules)"
    assert fresh_python(code).strip() == "False"
