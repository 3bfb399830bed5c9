"""A Chebyshev series on a tensor grid by sum factorisation, one direction at a time.

The box search (:mod:`fuzzymbs.fuzzy.box_search`) evaluates the adaptive method's
surrogate series ``s(x) = sum_d a_d prod_i T_(k_di)(x_i)`` (D terms, n directions) on a
tensor grid of every cut box. Term by term that costs ``D n`` per grid point. On a
tensor grid the directions separate: with the terms sorted by their multi-degrees, the
last direction is summed first for each distinct prefix ``(k_d1, ..., k_d(n-1))`` and
each of its grid values, then the next, down to the first (sum factorisation, Orszag,
J. Comput. Phys. 37 (1980) 70; the tensor-product evaluation of spectral methods):

    R_(n-1)[k_1..k_(n-1); x_n]         = sum_(d: prefix) a_d T_(k_dn)(x_n)
    R_(i-1)[k_1..k_(i-1); x_i..x_n]    = sum_(k_i) T_(k_i)(x_i) R_i[k_1..k_i; x_(i+1)..x_n]

so the last step is one matrix product ``T_1 R_1`` over the distinct first degrees. A
sparse grid's series has few distinct prefixes, so the work per grid point falls from
``D n`` to about the number of distinct first degrees (the box searches of the oscillator
at 0.5 % take 2.4 times less time in all, docs/fuzzy.md). The sums run in another
order than the term-by-term product, so the values agree with
:func:`~fuzzymbs.fuzzy.chebyshev_grid.evaluate_series` to round-off.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.chebyshev_grid import chebyshev_basis

__all__ = ["GridSeries"]


class GridSeries:
    """A series summed over every direction of a tensor grid but the first.

    Parameters
    ----------
    degrees, coefficients : the series, (D, n) and (D, E).
    axes : n arrays, the grid's values in each direction (unit coordinates); the grid's
        points are their combinations, the last direction varying fastest
        (:func:`~fuzzymbs.fuzzy.grids.cartesian`).

    Attributes
    ----------
    inner : grid points per value of the first direction (the product of the other
        directions' counts).
    """

    def __init__(
        self,
        degrees: NDArray[np.int64],
        coefficients: NDArray[np.float64],
        axes: Sequence[NDArray[np.float64]],
    ) -> None:
        degrees = np.asarray(degrees, dtype=np.int64)
        if degrees.ndim != 2 or degrees.shape[1] != len(axes):
            raise ValueError(f"degrees {degrees.shape} do not match {len(axes)} grid axes")
        order = np.lexsort(degrees.T[::-1])  # by the first degree, then the second, ...
        degrees = degrees[order]
        elements = coefficients.shape[1]
        partial = np.asarray(coefficients, dtype=float)[order][:, None, :]  # (rows, inner, E)
        for axis in range(len(axes) - 1, 0, -1):
            values = np.asarray(axes[axis], dtype=float)
            table = chebyshev_basis(values, int(degrees[:, axis].max(initial=0)))
            along = table[:, degrees[:, axis]].T  # (rows, points of this axis)
            grown = along[:, :, None, None] * partial[:, None, :, :]
            grown = grown.reshape(len(degrees), -1, elements)
            # the rows are sorted, so equal prefixes are neighbours
            prefix = degrees[:, :axis]
            first = np.flatnonzero(np.r_[True, np.any(prefix[1:] != prefix[:-1], axis=1)])
            partial = np.add.reduceat(grown, first, axis=0)
            degrees = degrees[first]
        self._first_degrees = degrees[:, 0]
        self._first_axis = np.asarray(axes[0], dtype=float)
        self.inner = partial.shape[1]
        self._partial = partial.reshape(len(degrees), -1)  # (distinct first degrees, inner E)
        self._elements = elements

    @staticmethod
    def entries(degrees: NDArray[np.int64], elements: int, axes: Sequence[NDArray]) -> int:
        """An upper bound of the float64 entries the sums hold at once (the first step's:
        every term times the last direction's points, later steps have fewer rows)."""
        inner = int(np.prod([len(axis) for axis in axes[1:]], dtype=np.int64))
        return max(1, len(degrees)) * inner * elements

    def values(self, first: slice) -> NDArray[np.float64]:
        """(points, E) the series at the grid points whose first coordinate is
        ``axes[0][first]``: rows ``first.start * inner`` onwards of the grid, in order."""
        points = self._first_axis[first]
        table = chebyshev_basis(points, int(self._first_degrees.max(initial=0)))
        return (table[:, self._first_degrees] @ self._partial).reshape(-1, self._elements)
