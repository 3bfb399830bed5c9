"""A symmetric system grown by bordering (block elimination with Schur complements,
Golub and Van Loan 2013, ch. 3) against NumPy's LU solve of the whole system."""

import numpy as np
import pytest

from fuzzymbs.fuzzy.bordered_system import BorderedSystem


def _saddle(count, seed=0):
    # a cubic-kernel system with its linear tail: symmetric, indefinite (Wendland 2005, ch. 8)
    points = np.random.default_rng(seed).uniform(-1.0, 1.0, (count, 2))
    kernel = np.linalg.norm(points[:, None] - points[None], axis=2) ** 3
    return kernel, np.column_stack((np.ones(count), points))


def test_grown_solves_equal_the_whole_systems_solve():
    kernel, tail = _saddle(60)
    first = 20  # the first block: 20 values and the tail (3 unknowns), then 40 in 3 steps
    order = np.r_[np.arange(first), 60 + np.arange(3), np.arange(first, 60)]
    whole = np.block([[kernel, tail], [tail.T, np.zeros((3, 3))]])[np.ix_(order, order)]
    system = BorderedSystem(whole[: first + 3, : first + 3])
    right = np.random.default_rng(1).normal(size=(63, 2))
    size = first + 3
    for grow in (15, 1, 24):
        border = whole[:size, size : size + grow]
        corner = whole[size : size + grow, size : size + grow]
        grown, solved = system.extended_solve(border, corner, right[: size + grow])
        system = system.extended(border, corner)
        size += grow
        expected = np.linalg.solve(whole[:size, :size], right[:size])
        # the condition number is ~1e5: agreement to 1e-9 of the solution's size
        scale = 1e-9 * np.abs(expected).max()
        np.testing.assert_allclose(system.solve(right[:size]), expected, atol=scale)
        np.testing.assert_allclose(solved, expected, atol=scale)
        np.testing.assert_allclose(grown.solve(right[:size]), expected, atol=scale)
    assert system.size == 63
    with pytest.raises(ValueError, match="right-hand side"):
        system.extended_solve(np.zeros((63, 1)), np.ones((1, 1)), np.ones((63, 1)))


def test_dependent_new_rows_and_wrong_shapes_are_refused():
    kernel, tail = _saddle(10, seed=2)
    whole = np.block([[kernel, tail], [tail.T, np.zeros((3, 3))]])
    system = BorderedSystem(whole)
    # a new row equal to an old one: the Schur complement is zero, not positive definite
    with pytest.raises(np.linalg.LinAlgError):
        system.extended(whole[:, :1], whole[:1, :1])
    with pytest.raises(ValueError, match="do not fit"):
        system.extended(np.ones((12, 1)), np.ones((1, 1)))
    with pytest.raises(ValueError, match="right-hand side"):
        system.solve(np.ones(5))
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        BorderedSystem(np.zeros((3, 3)))
    with pytest.raises(np.linalg.LinAlgError, match="not finite"):
        BorderedSystem(np.full((2, 2), np.nan))
    # the system it was grown from is left as it was
    assert system.size == 13 and system.extended(np.zeros((13, 0)), np.zeros((0, 0))).size == 13
