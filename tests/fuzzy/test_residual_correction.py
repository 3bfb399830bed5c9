"""The kernel correction of the adaptive surrogate: a cubic polyharmonic spline with a
linear part (Wendland, Scattered Data Approximation, 2005, ch. 8)."""

import numpy as np

from fuzzymbs.fuzzy.residual_correction import KernelCorrection


def _points(count, dimension, seed=3):
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (count, dimension))


def test_interpolates_its_data_and_reproduces_linear_functions():
    centres = _points(40, 3)
    moving = np.ones(3, dtype=bool)
    # two elements: arbitrary data, and a linear function, which the spline's linear
    # part reproduces exactly everywhere (its kernel weights vanish)
    linear = 0.5 - 2.0 * centres[:, 0] + 0.25 * centres[:, 2]
    data = np.column_stack((np.sin(3.0 * centres.sum(axis=1)), linear))
    correction = KernelCorrection(centres, data, moving)
    np.testing.assert_allclose(correction.values(centres), data, atol=1e-10)
    elsewhere = _points(200, 3, seed=4)
    expected = 0.5 - 2.0 * elsewhere[:, 0] + 0.25 * elsewhere[:, 2]
    np.testing.assert_allclose(correction.values(elsewhere)[:, 1], expected, atol=1e-10)
    # the per-point form picks each point's own element
    element = np.arange(len(elsewhere)) % 2
    np.testing.assert_allclose(
        correction.at(elsewhere, element),
        correction.values(elsewhere)[np.arange(len(elsewhere)), element],
        rtol=1e-12,
        atol=1e-14,
    )


def test_gradient_matches_central_differences():
    centres = _points(30, 2)
    data = np.cos(2.0 * centres[:, :1]) * centres[:, 1:]
    correction = KernelCorrection(centres, data, np.ones(2, dtype=bool))
    points = _points(25, 2, seed=5) * 0.9
    element = np.zeros(len(points), dtype=np.intp)
    gradient = correction.gradient_at(points, element)
    step = 1e-6
    for axis in range(2):
        shift = np.zeros(2)
        shift[axis] = step
        central = correction.at(points + shift, element) - correction.at(points - shift, element)
        # the cubic kernel is C^2: central differences are accurate to O(step^2)
        np.testing.assert_allclose(gradient[:, axis], central / (2 * step), rtol=1e-6, atol=1e-6)


def test_a_repeated_point_and_a_frozen_direction_keep_the_system_solvable():
    # the adaptive method's first round can run the modal point next to an equal node;
    # a parameter of zero width is one coordinate for every run
    centres = np.concatenate((_points(12, 2), np.zeros((1, 2))))
    centres = np.concatenate((centres, centres[-1:] + 1e-13))  # the same point twice
    centres = np.column_stack((centres, np.zeros(len(centres))))  # frozen third direction
    data = (centres[:, 0] ** 2 - centres[:, 1])[:, None]
    correction = KernelCorrection(centres, data, np.array([True, True, False]))
    assert len(correction.centres) == len(centres) - 1
    assert np.all(np.isfinite(correction.weights))
    np.testing.assert_allclose(correction.values(centres), data, atol=1e-10)
    assert np.all(correction.gradient_at(centres, np.zeros(len(centres), dtype=np.intp))[:, 2] == 0)
