"""Sets of sample points: full factorial grids and exact de-duplication.

Plans build their sample tables with these, and retransformation uses the same
functions for its search grids, so a point reached twice is recognised as one
(exact floating-point equality).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["cartesian", "nearest_distances", "unique_rows"]

#: float64 entries of one block of point-to-point distances in nearest_distances: 512 kB,
#: within the core's cache. Against 2,000,000 (benchmarks/correction_blocks.py, 2026-12-02,
#: Xeon host, best of 5; the same numbers): 60,030 points x 76 runs x 3 parameters 27.7
#: against 53.3 ms, 16,000 x 1,400 x 4 162 against 226 ms, 20,000 x 2,000 x 4 302 against 428 ms
_BLOCK_ENTRIES = 65_536


def cartesian(values: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    """All combinations of per-parameter values.

    Parameters
    ----------
    values : sequence of ndarray
        ``values[i]``: the values of parameter i, shape ``(k_i,)``.

    Returns
    -------
    ndarray, shape (prod k_i, n)
        One row per combination, the last parameter varying fastest.
    """
    grids = np.meshgrid(*values, indexing="ij")
    return np.stack([grid.reshape(-1) for grid in grids], axis=1)


def unique_rows(
    points: NDArray[np.float64], *, sort: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Unique rows by exact float equality, kept in order of first appearance.

    Unlike ``np.unique(axis=0)`` this compares values, not bytes, so -0.0 == 0.0.

    Parameters
    ----------
    points : ndarray, shape (P, n)
        Points, one per row.
    sort : bool
        The distinct rows in lexicographic order (the first column first), the
        order of ``np.unique(points, axis=0)``, instead of first appearance; for
        ten thousands of rows many times faster than ``np.unique``, which sorts
        them as structured records.

    Returns
    -------
    unique : ndarray, shape (U, n)
        The distinct rows, in the order in which they first occur in ``points``
        (or sorted).
    inverse : ndarray of intp, shape (P,)
        Row of ``unique`` for every row of ``points``: ``unique[inverse] == points``.
    """
    count = len(points)
    order = np.lexsort(points.T[::-1])
    sorted_points = points[order]
    new_group = np.ones(count, dtype=bool)
    new_group[1:] = np.any(sorted_points[1:] != sorted_points[:-1], axis=1)
    group_of_sorted = np.cumsum(new_group) - 1
    group = np.empty(count, dtype=np.intp)
    group[order] = group_of_sorted
    if sort:
        return sorted_points[new_group], group
    # renumber groups by first appearance in the original order
    first_position = np.full(group_of_sorted[-1] + 1, count, dtype=np.intp)
    np.minimum.at(first_position, group, np.arange(count))
    rank = np.empty_like(first_position)
    rank[np.argsort(first_position, kind="stable")] = np.arange(len(first_position))
    inverse = rank[group]
    unique = np.empty((len(first_position), points.shape[1]))
    unique[inverse] = points
    return unique, inverse


def nearest_distances(
    points: NDArray[np.float64], others: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(K,) each point's distance in the max norm to the nearest of ``others`` (M, n);
    inf where there are none.

    The same numbers as ``abs(points[:, None] - others[None]).max(axis=2).min(axis=1)``
    (a maximum and a minimum are exact), in blocks of points and one coordinate at a time,
    so that no (K, M, n) array is made: the adaptive method measures tens of thousands of
    extremal points against every run each round.
    """
    points = np.asarray(points, dtype=float)
    others = np.asarray(others, dtype=float)
    nearest = np.full(len(points), np.inf)
    if not len(others) or not len(points):
        return nearest
    if not points.shape[1]:
        return np.zeros(len(points))
    block = max(1, _BLOCK_ENTRIES // len(others))
    for start in range(0, len(points), block):
        part = points[start : start + block]
        gap = np.abs(part[:, None, 0] - others[None, :, 0])
        for i in range(1, points.shape[1]):
            np.maximum(gap, np.abs(part[:, None, i] - others[None, :, i]), out=gap)
        nearest[start : start + block] = gap.min(axis=1)
    return nearest
