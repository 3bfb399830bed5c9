"""The gradient-enhanced kernel correction: Hermite-Birkhoff interpolation of values and
gradients with the cubic polyharmonic kernel (Wendland, Scattered Data Approximation,
2005, ch. 16)."""

import numpy as np

from fuzzymbs.fuzzy.hermite_correction import HermiteCorrection
from fuzzymbs.fuzzy.residual_correction import KernelCorrection


def _points(count, dimension, seed=3):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (count, dimension))


def _function(x):
    # two elements: f0 = sin(2 x0) x1 + x2^2, f1 = exp(x0 - x1)
    return np.stack((np.sin(2.0 * x[:, 0]) * x[:, 1] + x[:, 2] ** 2, np.exp(x[:, 0] - x[:, 1])), 1)


def _gradient(x):
    out = np.zeros((len(x), 2, 3))
    out[:, 0, 0] = 2.0 * np.cos(2.0 * x[:, 0]) * x[:, 1]
    out[:, 0, 1] = np.sin(2.0 * x[:, 0])
    out[:, 0, 2] = 2.0 * x[:, 2]
    out[:, 1, 0] = np.exp(x[:, 0] - x[:, 1])
    out[:, 1, 1] = -out[:, 1, 0]
    return out


def test_interpolates_values_everywhere_and_gradients_where_given():
    centres = _points(25, 3)
    sloped = np.arange(len(centres)) % 3 != 0  # a third of the runs without a gradient
    correction = HermiteCorrection(
        centres, _function(centres), _gradient(centres), sloped, np.ones(3, dtype=bool)
    )
    np.testing.assert_allclose(correction.values(centres), _function(centres), atol=1e-12)
    for element in (0, 1):
        own = np.full(len(centres), element)
        np.testing.assert_allclose(
            correction.at(centres, own), _function(centres)[:, element], atol=1e-12
        )
        np.testing.assert_allclose(
            correction.gradient_at(centres, own)[sloped],
            _gradient(centres)[sloped, element],
            atol=1e-11,
        )


def test_gradient_matches_central_differences_and_forms_agree():
    centres = _points(20, 3, seed=7)
    correction = HermiteCorrection(
        centres, _function(centres), _gradient(centres), np.ones(20, bool), np.ones(3, bool)
    )
    points = _points(40, 3, seed=8) * 0.9
    element = np.arange(len(points)) % 2
    full = correction.values(points)[np.arange(len(points)), element]
    np.testing.assert_allclose(correction.at(points, element), full, rtol=1e-12, atol=1e-13)
    step = 1e-6
    gradient = correction.gradient_at(points, element)
    for axis in range(3):
        shift = np.zeros(3)
        shift[axis] = step
        central = correction.at(points + shift, element) - correction.at(points - shift, element)
        # the kernel terms are C^2 (|x|^3) and C^1 (|x| x): central differences to O(step^2)
        np.testing.assert_allclose(gradient[:, axis], central / (2 * step), rtol=1e-6, atol=1e-6)


def test_reproduces_linear_functions_and_gradients_make_it_more_accurate():
    centres = _points(30, 3, seed=11)
    moving = np.ones(3, dtype=bool)
    linear = lambda x: (0.5 - 2.0 * x[:, 0] + 0.25 * x[:, 2])[:, None]  # noqa: E731
    slope = np.tile(np.array([-2.0, 0.0, 0.25]), (len(centres), 1, 1))
    exact = HermiteCorrection(centres, linear(centres), slope, np.ones(30, bool), moving)
    elsewhere = _points(300, 3, seed=12)
    np.testing.assert_allclose(exact.values(elsewhere), linear(elsewhere), atol=1e-10)
    # values and gradients of a smooth function: far closer between the runs than the
    # value-only spline through the same runs
    hermite = HermiteCorrection(
        centres, _function(centres), _gradient(centres), np.ones(30, bool), moving
    )
    plain = KernelCorrection(centres, _function(centres), moving)
    truth = _function(elsewhere)
    assert (
        np.abs(hermite.values(elsewhere) - truth).mean()
        < 0.5 * np.abs(plain.values(elsewhere) - truth).mean()
    )


def test_without_gradients_it_is_the_value_only_spline_and_frozen_directions_drop_out():
    centres = np.column_stack((_points(15, 2), np.zeros(15)))  # a frozen third direction
    data = (centres[:, 0] ** 2 - centres[:, 1])[:, None]
    moving = np.array([True, True, False])
    hermite = HermiteCorrection(
        centres, data, np.zeros((15, 1, 3)), np.zeros(15, dtype=bool), moving
    )
    plain = KernelCorrection(centres, data, moving)
    points = np.column_stack((_points(50, 2, seed=5), np.zeros(50)))
    np.testing.assert_allclose(hermite.values(points), plain.values(points), atol=1e-10)
    element = np.zeros(50, dtype=np.intp)
    assert np.all(hermite.gradient_at(points, element)[:, 2] == 0.0)


def test_a_correction_grown_from_the_last_rounds_equals_one_solved_afresh():
    # rounds of runs as the adaptive method makes them: each round's centres continue the
    # last's (one run repeats an old centre and is dropped, some runs have no gradient);
    # the bordered system (fuzzymbs.fuzzy.bordered_system) against a fresh LU solve of the
    # whole system, which is a second method: equal to 1e-9 of the data's range (the
    # systems' condition numbers reach about 1e6 here, so both carry ~1e-10 of round-off)
    moving = np.ones(3, dtype=bool)
    points = _points(90, 3, seed=21)
    points[70] = points[12]
    sloped = np.arange(90) % 4 != 1
    previous = None
    for stop in (10, 35, 36, 71, 90):
        centres = points[:stop]
        grown = HermiteCorrection(
            centres, _function(centres), _gradient(centres), sloped[:stop], moving, previous
        )
        fresh = HermiteCorrection(
            centres, _function(centres), _gradient(centres), sloped[:stop], moving
        )
        assert grown._system is not None and fresh._system is not None
        if previous is not None:
            assert len(grown._system._levels) == len(previous._system._levels) + 1
        elsewhere = _points(200, 3, seed=stop)
        scale = np.ptp(_function(centres), axis=0)
        np.testing.assert_allclose(
            grown.values(elsewhere) / scale, fresh.values(elsewhere) / scale, atol=1e-9
        )
        np.testing.assert_allclose(grown.values(centres), _function(centres), atol=1e-10)
        previous = grown


def test_a_correction_that_does_not_continue_the_last_is_solved_afresh():
    moving = np.ones(3, dtype=bool)
    points = _points(30, 3, seed=31)
    first = HermiteCorrection(
        points[:20], _function(points[:20]), _gradient(points[:20]), np.ones(20, bool), moving
    )
    # other first centres, another frozen direction, other gradient flags: no bordering
    others = (
        (points[5:], np.ones(25, bool), moving),
        (points, np.ones(30, bool), np.array([True, True, False])),
        (points, np.arange(30) % 2 == 0, moving),
    )
    for centres, sloped, frozen in others:
        grown = HermiteCorrection(
            centres, _function(centres), _gradient(centres), sloped, frozen, first
        )
        assert grown._system is not None and len(grown._system._levels) == 0
        np.testing.assert_allclose(grown.values(centres), _function(centres), atol=1e-10)
