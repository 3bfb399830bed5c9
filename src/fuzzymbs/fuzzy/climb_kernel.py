"""The box search's projected gradient ascent, compiled: one start at a time, to its end.

:func:`fuzzymbs.fuzzy.box_search.climb` polishes every (box, element, bound) of the
adaptive method's surrogate from the best point of a search grid. The surrogate is a
Chebyshev series plus a kernel correction through the runs
(:mod:`fuzzymbs.fuzzy.residual_correction`, and with the model's gradients
:mod:`fuzzymbs.fuzzy.hermite_correction`), and a brake study climbs it from 60,030
starts per box search (six levels, two bounds, three signals of 2,001 points), most
of which stop at their first step. Compiled, each start reads only its element's
coefficients and weights and stops on its own; with arrays, every step would gather
every moving start's numbers and evaluate the basis and the kernel for all of them
(4.7 times slower on a brake-sized search, ``benchmarks/box_search.py``).

The surrogate of element ``e`` at ``x`` (the correction's coordinates: the moving
directions ``m``, ``d_p = x_m - c_p``, ``r_p = |d_p|``)::

    s(x) = sum_d a_de prod_i T_(k_di)(x_i)                     (the series)
         + sum_p w_pe r_p^3 + t_0e + sum_l t_le x_l             (the cubic correction)
         - 3 sum_g |x_m - y_g| (x_m - y_g) . v_ge               (the Hermite terms)

with the gradients of each term as in the modules above.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["climb_starts"]


@numba.njit(cache=True, nogil=True)
def _chebyshev(x: float, top: int, value: NDArray, slope: NDArray) -> None:
    """``T_a(x)`` and ``T_a'(x)`` for a = 0..top into ``value`` and ``slope`` (the
    recurrences of :func:`~fuzzymbs.fuzzy.chebyshev_grid.chebyshev_basis`)."""
    value[0] = 1.0
    slope[0] = 0.0
    if top >= 1:
        value[1] = x
        slope[1] = 1.0
    for a in range(2, top + 1):
        value[a] = 2.0 * x * value[a - 1] - value[a - 2]
        slope[a] = 2.0 * value[a - 1] + 2.0 * x * slope[a - 1] - slope[a - 2]


@numba.njit(cache=True, nogil=True)
def _evaluate(
    x: NDArray,
    e: int,
    series: tuple,
    tops: NDArray,
    correction: tuple,
    table: NDArray,
    table_slope: NDArray,
    gradient: NDArray,
) -> float:
    """The surrogate of element ``e`` at ``x``, and its gradient into ``gradient`` (zero
    along the directions that do not move); ``series`` and ``correction`` as
    :func:`climb_starts` takes them, ``table`` and ``table_slope`` room for the
    Chebyshev values."""
    degrees, coefficients = series
    moving, centres, weights, tail, slope_centres, slope_weights = correction
    count = x.shape[0]
    for i in range(count):
        _chebyshev(x[i], tops[i], table[i], table_slope[i])
        gradient[i] = 0.0
    total = 0.0
    for d in range(degrees.shape[0]):
        a = coefficients[e, d]
        product = 1.0
        for i in range(count):
            product *= table[i, degrees[d, i]]
        total += a * product
        for i in range(count):
            if not moving[i]:
                continue
            part = table_slope[i, degrees[d, i]]
            for q in range(count):
                if q != i:
                    part *= table[q, degrees[d, q]]
            gradient[i] += a * part
    # the cubic correction: sum_p w_p r_p^3 + t_0 + t_l x_l over the moving coordinates
    if tail.shape[1] > 0:
        total += tail[e, 0]
        column = 1
        for i in range(count):
            if moving[i]:
                total += tail[e, column] * x[i]
                gradient[i] += tail[e, column]
                column += 1
    for p in range(centres.shape[0]):
        squared = 0.0
        column = 0
        for i in range(count):
            if moving[i]:
                delta = x[i] - centres[p, column]
                squared += delta * delta
                column += 1
        r = np.sqrt(squared)
        w = weights[e, p]
        total += w * r * r * r
        column = 0
        for i in range(count):
            if moving[i]:
                gradient[i] += 3.0 * r * w * (x[i] - centres[p, column])
                column += 1
    # the Hermite terms: -3 sum_g r_g (d_g . v_g), gradient -3 (r_g v_g + d_g (d_g . v_g) / r_g)
    for g in range(slope_centres.shape[0]):
        squared = 0.0
        dot = 0.0
        column = 0
        for i in range(count):
            if moving[i]:
                delta = x[i] - slope_centres[g, column]
                squared += delta * delta
                dot += delta * slope_weights[e, g, column]
                column += 1
        r = np.sqrt(squared)
        total -= 3.0 * r * dot
        ratio = dot / r if r > 0.0 else 0.0
        column = 0
        for i in range(count):
            if moving[i]:
                delta = x[i] - slope_centres[g, column]
                gradient[i] -= 3.0 * (r * slope_weights[e, g, column] + ratio * delta)
                column += 1
    return total


@numba.njit(cache=True, nogil=True)
def climb_starts(
    series: tuple,
    starts: NDArray,
    element: NDArray,
    sign: NDArray,
    low: NDArray,
    high: NDArray,
    correction: tuple,
    steps: int,
) -> tuple[NDArray, NDArray]:
    """Projected gradient ascent of ``sign[k] * s_(element[k])`` from every start in its
    box ``[low[k], high[k]]``: a step of 0.05 of the box's widest side along the
    normalised gradient, clipped to the box, kept if it improves (the step then grows by
    1.5) or not (it halves), at most ``steps`` times; a start whose gradient points out
    of its box wherever it is not zero stops.

    Parameters
    ----------
    series : (degrees (D, n) int, coefficients (E, D)): the Chebyshev series, one row of
        coefficients per element.
    starts, low, high : (K, n) unit coordinates.
    element : (K,) int; sign : (K,) +1 (maximum) or -1 (minimum).
    correction : (moving, centres, weights, tail, slope_centres, slope_weights):
        ``moving`` (n,) bool, the correction's directions (m of them); the cubic
        correction's ``centres`` (P, m), ``weights`` (E, P) and ``tail`` (E, 1 + m), or
        (E, 0) for none; the Hermite terms' ``slope_centres`` (G, m) and
        ``slope_weights`` (E, G, m) (G = 0: none).
    steps : the most steps a start takes.

    Returns
    -------
    points : (K, n) where each search ended; values : (K,) the surrogate there.
    """
    degrees = series[0]
    count, n = starts.shape
    tops = np.zeros(n, dtype=np.int64)
    for d in range(degrees.shape[0]):
        for i in range(n):
            tops[i] = max(tops[i], degrees[d, i])
    for i in range(n):
        tops[i] = max(tops[i], 1)
    size = tops.max() + 1
    table = np.empty((n, size))
    table_slope = np.empty((n, size))
    gradient = np.empty(n)
    trial_gradient = np.empty(n)
    direction = np.empty(n)
    points = starts.copy()
    values = np.empty(count)
    trial = np.empty(n)
    for k in range(count):
        e = element[k]
        x = points[k]
        width = 0.0
        for i in range(n):
            width = max(width, high[k, i] - low[k, i])
        step = 0.05 * max(width, 1e-300)
        # value and gradient in one pass over the centres; a rejected trial leaves both
        value = _evaluate(x, e, series, tops, correction, table, table_slope, gradient)
        for _ in range(steps):
            norm = 0.0
            inward = False
            for i in range(n):
                slope = sign[k] * gradient[i] if high[k, i] > low[k, i] else 0.0
                direction[i] = slope
                norm += slope * slope
                if (slope > 0.0 and x[i] < high[k, i]) or (slope < 0.0 and x[i] > low[k, i]):
                    inward = True
            if not inward:
                break  # its clipped trial would be itself
            norm = np.sqrt(norm)
            for i in range(n):
                trial[i] = min(max(x[i] + step * direction[i] / norm, low[k, i]), high[k, i])
            trial_value = _evaluate(
                trial, e, series, tops, correction, table, table_slope, trial_gradient
            )
            if sign[k] * trial_value > sign[k] * value:
                x[:] = trial
                gradient[:] = trial_gradient
                value = trial_value
                step *= 1.5
            else:
                step *= 0.5
        values[k] = value
    return points, values
