"""First-order conditions of the adaptive method's extrema, checked on the model's gradients.

The adaptive method (:mod:`fuzzymbs.fuzzy.adaptive`) reports per alpha-cut, output
element and side the extremum ``x*`` of its surrogate over the cut box, and
certifies its *value* by running the model at (or within ``near`` of) ``x*``.
Where the model also returns its gradient ``g`` there, the *place* can be
checked too: at a maximum of ``f`` over a box (Karush-Kuhn-Tucker, first
order) the projected gradient vanishes,

    p_i = g_i                    where x_i lies inside the box,
    p_i = max(g_i, 0) ... 0      at an active bound the gradient may point out of
                                 (the upper bound: g_i >= 0; the lower: g_i <= 0),

and ``p = 0`` (for a minimum the same with ``-g``). A run whose projected
gradient does not vanish says the model rises beyond the reported bound
nearby. How far is judged on the cut-width scale: the gain of the quadratic
model ``m(d) = p . d + d^T H d / 2`` over steps ``d`` that stay in the box, with
``H`` the surrogate's Hessian at the run (the surrogate interpolates the run's
value and gradient, so ``H`` is the best curvature the method knows there; a
direction of zero or positive curvature runs to the box's face: the gradient
times the remaining distance). Two steps are tried, the better kept:

1. a Newton step in the eigenvectors ``v`` of ``H`` over the free coordinates
   (``d = sum_v (p . v) / |lambda_v| v`` where ``lambda_v < 0``, to the face
   otherwise), clipped to the box;
2. the exact maximiser of ``m`` along ``p`` within the box.

The gain over the cut-width scale is the extremum's *first-order gap*; the step's
end is where the model should run next (a projected-gradient, Newton-like step
on the true model: its run joins the surrogate like every run off the grid).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.extremum_confirmation import surrogate_hessian
from fuzzymbs.fuzzy.residual_correction import KernelCorrection

__all__ = ["FirstOrder", "first_order_check", "first_order_steps", "open_gap"]

#: a coordinate closer than this to its box bound lies on the face (unit cube)
_ON_FACE = 1e-9
#: curvature (unit cube, cut-width units per unit^2) below which a direction counts as flat
_FLAT_CURVATURE = 1e-12


@dataclass(frozen=True)
class FirstOrder:
    """The first-order check of every extremum (one row per level, element and side).

    Attributes
    ----------
    gap : ndarray (K,)
        The first-order gap on the cut-width scale (NaN: no run with a gradient within
        ``near`` of the extremum, so it is not checked).
    step : ndarray (K, n)
        Where the step from the confirming run ends (unit cube); the extremum itself
        where there is no confirming run.
    extremum : ndarray (K, n)
        The surrogate's extremal point.
    run : ndarray (K,) of int
        The confirming run (-1: none).
    """

    gap: NDArray[np.float64]
    step: NDArray[np.float64]
    extremum: NDArray[np.float64]
    run: NDArray[np.intp]


def first_order_check(
    surrogate: tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None],
    arg_lower: NDArray[np.float64],
    arg_upper: NDArray[np.float64],
    box: tuple[NDArray[np.float64], NDArray[np.float64]],
    scale: NDArray[np.float64],
    runs: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]],
    moving: NDArray[np.bool_],
    near: float,
    reported: tuple[NDArray[np.float64], NDArray[np.float64]],
) -> FirstOrder:
    """The first-order gap of every extremum at its confirming run (module docstring).

    Parameters
    ----------
    surrogate : (degrees, coefficients, correction) of the adaptive method.
    arg_lower, arg_upper : ndarray (L, E, n)
        The surrogate's extremal points per level and element (unit cube).
    box : (low, high), each (L, n): the cut boxes (unit cube).
    scale : ndarray (L, E)
        The cut-width scale (inf: a crisp cut, nothing to check: left out).
    runs : (units (N, n), values (N, E), slopes (N, E, n), sloped (N,))
        Every run (unit cube), the model's outputs and gradients there (unit coordinates)
        and which runs have one.
    moving : ndarray (n,) of bool
        Parameters that vary.
    near : float
        A run at most this far (max norm over the moving coordinates) from an extremum
        confirms it.
    reported : (lower, upper), each (L, E)
        The bounds the method reports: the gap is how far the run's value plus the gain
        reaches beyond the bound of its side (a run below a maximum the surrogate already
        reports higher gains nothing the bound misses).

    Returns
    -------
    FirstOrder
        Rows in the order minimum then maximum, level-major, element-minor, only those
        with a finite scale and a box of some width.
    """
    box_low, box_high = box
    units, values, slopes, sloped = runs
    count_levels, elements, dimension = arg_lower.shape
    points = np.concatenate((arg_lower.reshape(-1, dimension), arg_upper.reshape(-1, dimension)))
    level = np.tile(np.repeat(np.arange(count_levels), elements), 2)
    element = np.tile(np.arange(elements), 2 * count_levels)
    sign = np.repeat([-1.0, 1.0], count_levels * elements)
    width = scale[level, element]
    keep = np.isfinite(width) & np.any(box_high[level] > box_low[level], axis=1)
    points, level, element, sign, width = (a[keep] for a in (points, level, element, sign, width))
    low, high = box_low[level], box_high[level]
    count = len(points)
    gap = np.full(count, np.nan)
    step = points.copy()
    run = np.full(count, -1, dtype=np.intp)
    candidates = np.flatnonzero(sloped)
    if not count or not len(candidates):
        return FirstOrder(gap, step, points, run)
    # the nearest run with a gradient, within near
    distance = np.abs(points[:, None, moving] - units[candidates][None, :, moving]).max(axis=2)
    nearest = np.argmin(distance, axis=1)
    close = distance[np.arange(count), nearest] <= near
    run[close] = candidates[nearest[close]]
    rows = np.flatnonzero(close)
    if not len(rows):
        return FirstOrder(gap, step, points, run)
    here = np.clip(units[run[rows]], low[rows], high[rows])
    lo, hi = low[rows], high[rows]
    g = sign[rows, None] * slopes[run[rows], element[rows]]
    g = np.where(moving & (hi > lo), g, 0.0)
    # projected gradient: an active bound the gradient points out of holds the extremum
    out_high = (here >= hi - _ON_FACE) & (g > 0.0)
    out_low = (here <= lo + _ON_FACE) & (g < 0.0)
    p = np.where(out_high | out_low, 0.0, g)
    free = (p != 0.0) | ((here > lo + _ON_FACE) & (here < hi - _ON_FACE) & moving & (hi > lo))
    hessian = surrogate_hessian(surrogate, here, element[rows], sign[rows], free)
    gain, move = _quadratic_ascent(p, hessian, here, lo, hi, free)
    bound = np.where(sign > 0.0, reported[1][level, element], reported[0][level, element])
    # beyond the reported bound: (f + gain - upper) for a maximum, (lower - f + gain) for a minimum
    short = sign[rows] * (values[run[rows], element[rows]] - bound[rows])
    gap[rows] = np.maximum(short + gain, 0.0) / width[rows]
    step[rows] = np.clip(here + move, lo, hi)
    return FirstOrder(gap, step, points, run)


def _quadratic_ascent(
    p: NDArray[np.float64],
    hessian: NDArray[np.float64],
    here: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    free: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The gain ``max m(d)`` of ``m(d) = p . d + d^T H d / 2`` (K,) over the two steps of
    the module docstring, and the step ``d`` (K, n) that gives it (zero where no step
    gains)."""
    count, dimension = p.shape

    def model(d: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.einsum("ki,ki->k", p, d) + 0.5 * np.einsum("ki,kij,kj->k", d, hessian, d)

    # 1. Newton in the eigenvectors of H over the free coordinates (a fixed coordinate gets
    # a sentinel curvature, so that its eigenvector is its own axis and its step zero)
    sentinel = -1e300
    diagonal = np.arange(dimension)
    matrix = hessian.copy()
    matrix[:, diagonal, diagonal] = np.where(free, matrix[:, diagonal, diagonal], sentinel)
    curvature, vectors = np.linalg.eigh(matrix)
    along = np.einsum("kiq,ki->kq", vectors, p)
    span = 4.0  # beyond the unit cube's width: a flat or rising direction runs to the face
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.where(curvature < -_FLAT_CURVATURE, along / -curvature, np.sign(along) * span)
    reach = np.where(curvature > 0.5 * sentinel, reach, 0.0)
    newton = np.einsum("kiq,kq->ki", vectors, reach)
    newton = np.where(free, np.clip(here + newton, low, high) - here, 0.0)
    # 2. along the projected gradient, the exact maximiser within the box
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(
            p > 0.0, (high - here) / p, np.where(p < 0.0, (low - here) / p, np.inf)
        ).min(axis=1)
    power = np.einsum("ki,ki->k", p, p)
    bend = np.einsum("ki,kij,kj->k", p, hessian, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        length = np.where(bend < 0.0, np.minimum(power / -bend, room), room)
    length = np.where(np.isfinite(length) & (power > 0.0), length, 0.0)
    line = np.clip(here + length[:, None] * p, low, high) - here
    steps = np.stack((np.zeros((count, dimension)), newton, line))  # (3, K, n)
    gains = np.stack([model(d) for d in steps])
    best = np.argmax(gains, axis=0)
    return gains[best, np.arange(count)], steps[best, np.arange(count)]


def first_order_steps(
    check: FirstOrder,
    runs: NDArray[np.float64],
    moving: NDArray[np.bool_],
    *,
    tolerance: float,
    near: float,
    limit: int,
) -> NDArray[np.float64]:
    """The steps (P, n) of the extrema whose first-order gap exceeds ``tolerance``, the
    largest gap first, each farther than ``near`` (max norm over the moving coordinates)
    from every run and every step chosen (a shorter step is below the resolution of the
    runs), at most ``limit``: one batch for the model. None: every extremum a run confirms
    meets its first-order conditions to the tolerance."""
    violated = np.flatnonzero(check.gap > tolerance)
    violated = violated[np.argsort(-check.gap[violated], kind="stable")]
    chosen: list[NDArray[np.float64]] = []
    taken = runs[:, moving]
    for point in check.step[violated]:
        if len(chosen) >= limit:
            break
        others = np.concatenate((taken, np.array(chosen).reshape(-1, len(point))[:, moving]))
        if not len(others) or np.abs(others - point[moving]).max(axis=1).min() > near:
            chosen.append(point)
    return np.array(chosen).reshape(-1, runs.shape[1])


def open_gap(
    check: FirstOrder, runs: NDArray[np.float64], moving: NDArray[np.bool_], near: float
) -> float:
    """The largest first-order gap of the extrema whose step has not been taken (0 if none).

    A step that ends within ``near`` (max norm over the moving coordinates) of a run has
    been measured: the quadratic model put its largest gain there, and the run's value
    lies within the reported bounds (they are widened to every run), so that gain did
    not occur. Such a gap would otherwise stay open as long as the surrogate's curvature
    at the confirming run predicts it, although no step can close it (measured on the
    brake's study 1: a curvature along a parameter the output hardly depends on kept a
    3.7 to 14 % gap open for four rounds, refining the grid in each).

    Parameters
    ----------
    check : the first-order check (:func:`first_order_check`).
    runs : ndarray (N, n)
        Every run (unit cube).
    moving : ndarray (n,) of bool
        Parameters that vary.
    near : float
        A run at most this far from a step's end has taken the step.

    Returns
    -------
    float
        The largest gap of the other extrema (NaN gaps, the unchecked, count as none).
    """
    if not len(check.gap):
        return 0.0
    ends = check.step[:, moving]
    taken = np.zeros(len(ends), dtype=bool)
    if len(runs):
        distance = np.abs(ends[:, None, :] - runs[None, :, moving]).max(axis=2)
        taken = distance.min(axis=1) <= near
    return float(np.nanmax(np.where(taken, 0.0, check.gap), initial=0.0))
