"""Unique rows of a point set against NumPy's ``np.unique(axis=0)``."""

from __future__ import annotations

import numpy as np
import pytest

import fuzzymbs.fuzzy.grids as grids
from fuzzymbs.fuzzy.grids import nearest_distances, unique_rows


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


def test_nearest_distances_equal_the_direct_formula(monkeypatch):
    # the reference: the (K, M, n) array of coordinate gaps, maximum over n, minimum over M
    # (the formula the blocked version replaced); equal to the bit, also with blocks of 7
    # points (the last one short) and with ties and repeated points
    rng = np.random.default_rng(3)
    points = rng.uniform(-1.0, 1.0, (50, 3))
    others = np.concatenate((rng.uniform(-1.0, 1.0, (20, 3)), points[:5]))
    direct = np.abs(points[:, None, :] - others[None, :, :]).max(axis=2).min(axis=1)
    np.testing.assert_array_equal(nearest_distances(points, others), direct)
    assert np.all(nearest_distances(points, others)[:5] == 0.0)
    monkeypatch.setattr(grids, "_BLOCK_ENTRIES", 7 * len(others))
    np.testing.assert_array_equal(nearest_distances(points, others), direct)
    assert np.all(np.isinf(nearest_distances(points, np.empty((0, 3)))))
    assert nearest_distances(np.empty((0, 3)), others).shape == (0,)
