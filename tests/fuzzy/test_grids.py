"""Unique rows of a point set against NumPy's ``np.unique(axis=0)``."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.fuzzy.grids import unique_rows


@pytest.mark.parametrize("sort", [False, True])
def test_unique_rows_against_numpy(sort):
    # reference: np.unique(axis=0) (lexicographic order); 5000 rows of a 3-d grid of
    # 7 values per axis, so most rows repeat, some coordinates negative
    rng = np.random.default_rng(4)
    points = rng.integers(-3, 4, size=(5000, 3)) / 3.0
    unique, inverse = unique_rows(points, sort=sort)
    expected, expected_inverse = np.unique(points, axis=0, return_inverse=True)
    np.testing.assert_array_equal(unique[inverse], points)
    assert len(unique) == len(expected)
    if sort:
        np.testing.assert_array_equal(unique, expected)
        np.testing.assert_array_equal(inverse, expected_inverse.ravel())
    else:  # first appearance
        first = [int(np.flatnonzero(inverse == row)[0]) for row in range(len(unique))]
        assert first == sorted(first)


def test_unique_rows_merges_signed_zeros():
    points = np.array([[0.0, 1.0], [-0.0, 1.0], [0.5, -0.0]])
    for sort in (False, True):
        unique, inverse = unique_rows(points, sort=sort)
        assert len(unique) == 2 and inverse[0] == inverse[1]
