"""Extremes of a Chebyshev series over boxes, for every output element at once.

The adaptive transformation method bounds each alpha-cut box by the minimum
and maximum of its surrogate (:mod:`fuzzymbs.fuzzy.chebyshev_grid`) there, per
output element. Two steps:

1. a tensor grid of the box whose spacing follows the series' degree in each
   direction (about two points per half-oscillation of the highest Chebyshev
   polynomial over the box's share of ``[-1, 1]``): the best grid point of every
   element and bound;
2. a projected gradient search of the series from each of those points, all
   elements and bounds at once (a step per start that grows by 1.5 after an
   improvement and halves otherwise), so that an extremum between grid points
   is found to round-off of the series rather than the grid spacing.
"""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.chebyshev_grid import basis_matrix
from fuzzymbs.fuzzy.grid_series import GridSeries
from fuzzymbs.fuzzy.grids import cartesian
from fuzzymbs.fuzzy.hermite_correction import HermiteCorrection
from fuzzymbs.fuzzy.residual_correction import KernelCorrection

__all__ = ["box_extremes", "climb"]

#: gradient steps of the polishing search
_STEPS = 40
#: starts per thread at least before the search is split over threads
_STARTS_PER_THREAD = 2048
#: float64 elements of one block of basis values on the search grid
_BLOCK_ELEMENTS = 4_000_000


def _grid_axes(
    degrees: NDArray[np.int64], low: NDArray, high: NDArray, budget: int
) -> list[NDArray[np.float64]]:
    """Per direction the search grid of the box [low, high] (unit coordinates)."""
    top = degrees.max(axis=0) if len(degrees) else np.zeros(len(low), dtype=np.int64)
    share = (high - low) / 2.0
    counts = np.where(high > low, np.ceil(2.0 * top * share).astype(int) + 3, 1)
    while np.prod(counts.astype(float)) > budget and counts.max() > 3:
        counts = np.where(counts > 3, np.maximum(3, (counts * 0.9).astype(int)), counts)
    return [np.unique(np.linspace(lo, hi, c)) for lo, hi, c in zip(low, high, counts, strict=True)]


def box_extremes(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    *,
    budget: int = 20_000,
    correction: KernelCorrection | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Minimum and maximum of a series (plus a kernel correction) over boxes, per element.

    Parameters
    ----------
    degrees, coefficients : the series (D, n) and (D, E).
    low, high : (L, n) the boxes in unit coordinates (``[-1, 1]``).
    budget : search-grid points per box at most.
    correction : added to the series where given (the runs off the grid,
        :mod:`fuzzymbs.fuzzy.residual_correction`).

    Returns
    -------
    lower, upper : (L, E) the smallest and largest value found.
    arg_lower, arg_upper : (L, E, n) where.
    """
    count_boxes, count = low.shape
    elements = coefficients.shape[1]
    lower = np.empty((count_boxes, elements))
    upper = np.empty((count_boxes, elements))
    arg_lower = np.empty((count_boxes, elements, count))
    arg_upper = np.empty((count_boxes, elements, count))
    for j in range(count_boxes):
        axes = _grid_axes(degrees, low[j], high[j], budget)
        grid = cartesian(axes)
        centres = 0 if correction is None else len(correction.centres)
        block = max(1, _BLOCK_ELEMENTS // max(len(degrees), elements, centres))
        best_low = np.full(elements, np.inf)
        best_high = np.full(elements, -np.inf)
        where_low = np.zeros(elements, dtype=np.intp)
        where_high = np.zeros(elements, dtype=np.intp)
        for start, values in _grid_blocks(degrees, coefficients, axes, grid, block):
            if correction is not None:
                values += correction.values(grid[start : start + len(values)])
            small, large = values.argmin(axis=0), values.argmax(axis=0)
            take = np.arange(elements)
            low_value, high_value = values[small, take], values[large, take]
            better = low_value < best_low
            best_low[better], where_low[better] = low_value[better], small[better] + start
            better = high_value > best_high
            best_high[better], where_high[better] = high_value[better], large[better] + start
        lower[j], upper[j] = best_low, best_high
        arg_lower[j], arg_upper[j] = grid[where_low], grid[where_high]
    # polish every (box, element, bound) at once
    starts = np.concatenate((arg_lower.reshape(-1, count), arg_upper.reshape(-1, count)))
    sign = np.concatenate((-np.ones(count_boxes * elements), np.ones(count_boxes * elements)))
    element = np.tile(np.arange(elements), 2 * count_boxes)
    box = np.tile(np.repeat(np.arange(count_boxes), elements), 2)
    found, value = climb(
        degrees, coefficients, starts, element, sign, low[box], high[box], correction
    )
    half = count_boxes * elements
    lower = np.minimum(lower, value[:half].reshape(count_boxes, elements))
    upper = np.maximum(upper, value[half:].reshape(count_boxes, elements))
    improved_low = value[:half].reshape(count_boxes, elements) <= lower
    improved_high = value[half:].reshape(count_boxes, elements) >= upper
    arg_lower[improved_low] = found[:half].reshape(count_boxes, elements, count)[improved_low]
    arg_upper[improved_high] = found[half:].reshape(count_boxes, elements, count)[improved_high]
    return lower, upper, arg_lower, arg_upper


def _grid_blocks(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    axes: list[NDArray[np.float64]],
    grid: NDArray[np.float64],
    block: int,
) -> Iterator[tuple[int, NDArray[np.float64]]]:
    """``(first row, values (rows, E))`` of the series on ``grid``, the tensor grid of
    ``axes`` (:func:`~fuzzymbs.fuzzy.grids.cartesian`), in blocks of about ``block`` rows:
    summed one direction at a time (:class:`~fuzzymbs.fuzzy.grid_series.GridSeries`) where
    its sums fit in ``_BLOCK_ELEMENTS`` entries (few output elements), else term by term."""
    elements = coefficients.shape[1]
    if len(degrees) and GridSeries.entries(degrees, elements, axes) <= _BLOCK_ELEMENTS:
        series = GridSeries(degrees, coefficients, axes)
        slab = max(1, block // series.inner)  # values of the first direction per block
        for first in range(0, len(axes[0]), slab):
            yield first * series.inner, series.values(slice(first, first + slab))
        return
    for start in range(0, len(grid), block):
        yield start, basis_matrix(degrees, grid[start : start + block]) @ coefficients


def values_at(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    points: NDArray[np.float64],
    element: NDArray[np.intp],
    correction: KernelCorrection | None = None,
) -> NDArray[np.float64]:
    """(K,) element ``element[k]`` of the series (plus the correction) at ``points[k]``."""
    values = np.einsum("kd,dk->k", basis_matrix(degrees, points), coefficients[:, element])
    return values if correction is None else values + correction.at(points, element)


def climb(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    starts: NDArray[np.float64],
    element: NDArray[np.intp],
    sign: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    correction: KernelCorrection | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Projected gradient ascent of ``sign * series[element]`` (plus the correction) from
    every start in its box (:func:`box_extremes`'s search, and the extremum confirmation's).

    Compiled (:func:`fuzzymbs.fuzzy.climb_kernel.climb_starts`): each start climbs on its
    own, reading only its element's coefficients and weights, and stops when its slope
    points out of its box wherever it is not zero (a corner or face extremum, most starts
    of a monotonic output: its clipped trial would be itself; the brake's study 1: 80 to
    98 % of the starts stop at the first step). From ``2 x 2,048`` starts on, every
    ``t``-th start goes to one of ``numba.get_num_threads()`` threads (one on a Dask
    worker that runs one task per core); the numbers do not depend on the split.

    Parameters
    ----------
    degrees, coefficients : the series (D, n) and (D, E).
    starts : (K, n) points (unit coordinates), each inside its box.
    element : (K,) the element each start climbs.
    sign : (K,) +1 to climb to a maximum, -1 to a minimum.
    low, high : (K, n) each start's box (a face where ``low == high`` in a direction).
    correction : added to the series where given.

    Returns
    -------
    points : (K, n) where each search ended.
    values : (K,) the series (plus correction) there.

    """
    # imported here: the fuzzy engine loads Numba (0.18 s) only when it climbs
    import numba

    from fuzzymbs.fuzzy.climb_kernel import climb_starts

    dimension = starts.shape[1]
    elements = coefficients.shape[1]
    moving = np.ones(dimension, dtype=bool)
    centres = slope_centres = np.empty((0, dimension))
    weights = tail = np.empty((elements, 0))
    slope_weights = np.empty((elements, 0, dimension))
    if correction is not None:
        moving = np.asarray(correction.moving, dtype=bool)
        centres, weights, tail = correction.centres, correction.weights.T, correction.tail.T
        if isinstance(correction, HermiteCorrection):
            slope_centres = correction.slope_centres
            slope_weights = correction.slope_weights.transpose(2, 0, 1)
    c = np.ascontiguousarray
    series = (c(degrees, dtype=np.int64), c(coefficients.T, dtype=float))
    kernel_correction = (
        moving, c(centres, dtype=float), c(weights, dtype=float), c(tail, dtype=float),
        c(slope_centres, dtype=float), c(slope_weights, dtype=float),
    )  # fmt: skip
    starts, element, sign = c(starts, dtype=float), c(element, dtype=np.int64), c(sign, dtype=float)
    low, high = c(low, dtype=float), c(high, dtype=float)

    def part(rows: slice) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        these = (starts[rows], element[rows], sign[rows], low[rows], high[rows])
        return climb_starts(series, *map(c, these), kernel_correction, _STEPS)

    # each start climbs on its own, so ranges of starts on the threads Numba may use (the
    # kernel releases the GIL) give the same numbers whatever the split
    threads = min(numba.get_num_threads(), max(1, len(starts) // _STARTS_PER_THREAD))
    if threads <= 1:
        return part(slice(None))
    # every threads-th start to a thread: neighbouring starts (one box, one bound) cost alike
    with ThreadPoolExecutor(threads) as pool:
        parts = list(pool.map(part, [slice(t, None, threads) for t in range(threads)]))
    points, values = np.empty_like(starts), np.empty(len(starts))
    for t, (found, value) in enumerate(parts):
        points[t::threads], values[t::threads] = found, value
    return points, values
