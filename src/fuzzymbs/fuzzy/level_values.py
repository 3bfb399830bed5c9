"""The values each parameter takes at each level, and the number of distinct points they make.

The reduced, extended, general and grid plans evaluate, at level j, the full
factorial of one value set per parameter. :func:`bound_value_sets` and
:func:`grid_value_sets` build those
sets (the plan builder's own), and :func:`union_size` counts the distinct points
of the union over the levels, plus the modal point, from the sets alone: the
exact ``len(plan(...))`` at a cost linear in the parameters, without building a
single point.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["bound_value_sets", "general_points", "grid_value_sets", "union_size"]


def general_points(lower: NDArray, upper: NDArray) -> list[NDArray[np.float64]]:
    """Per-level point sets P_j of one parameter for the general method (Hanss 2002).

    Parameters
    ----------
    lower, upper : ndarray, shape (L,)
        The parameter's cut bounds from mu = 0 to 1.

    Returns
    -------
    list of ndarray
        ``P_j`` for j = 0..L-1: the core bounds at the top level, then the cut
        bounds with the midpoints of consecutive points of the level above.
    """
    top = len(lower) - 1
    current = np.unique(np.array([lower[top], upper[top]]))
    points: list[NDArray[np.float64]] = [current]
    built = current  # every value of the levels above, sorted
    # a midpoint that equals a value of a level above up to rounding is that value: for
    # a number symmetric about its core and evenly spaced levels, P_j's inner points are
    # P_(j+2) (Hanss's count), which rounding at non-dyadic levels would otherwise split
    scale = 8.0 * np.finfo(np.float64).eps * float(np.max(np.abs([lower, upper])))
    for j in range(top - 1, -1, -1):
        inner = 0.5 * (current[:-1] + current[1:])
        nearest = np.clip(np.searchsorted(built, inner), 1, len(built)) - 1
        for offset in (0, 1):
            candidate = built[np.minimum(nearest + offset, len(built) - 1)]
            inner = np.where(np.abs(candidate - inner) <= scale, candidate, inner)
        current = np.concatenate(([lower[j]], inner, [upper[j]]))
        built = np.unique(np.concatenate((built, current)))
        points.append(current)
    return points[::-1]


def bound_value_sets(
    cut_lower: NDArray[np.float64], cut_upper: NDArray[np.float64], interior: Sequence[bool]
) -> list[list[NDArray[np.float64]]]:
    """``values[j][i]``: the cut bounds ``{a^(j), b^(j)}`` of parameter i at level j, or the
    general method's points ``P_j`` for the parameters marked ``interior`` (the reduced,
    extended and general methods).

    Parameters
    ----------
    cut_lower, cut_upper : ndarray, shape (L, n)
        Cut bounds of every parameter at every level.
    interior : sequence of bool, length n
        Parameters that take the general method's points.
    """
    count_levels, count_parameters = cut_lower.shape
    low, high = cut_lower, cut_upper
    general = {
        i: general_points(low[:, i], high[:, i]) for i in range(count_parameters) if interior[i]
    }
    return [
        [
            general[i][j] if i in general else np.array([low[j, i], high[j, i]])
            for i in range(count_parameters)
        ]
        for j in range(count_levels)
    ]


def grid_value_sets(
    cut_lower: NDArray[np.float64], cut_upper: NDArray[np.float64]
) -> list[list[NDArray[np.float64]]]:
    """``values[j][i]``: every cut bound of parameter i at levels j..m (the grid method)."""
    count_levels, count_parameters = cut_lower.shape
    low, high = cut_lower, cut_upper
    return [
        [np.unique(np.concatenate((low[j:, i], high[j:, i]))) for i in range(count_parameters)]
        for j in range(count_levels)
    ]


def union_size(values: Sequence[Sequence[NDArray[np.float64]]], modal: Sequence[float]) -> int:
    """Distinct points of the union over levels j of the products ``values[j][0] x ...``,
    plus the modal point: ``len(plan(...))``.

    Two points are one when every coordinate is equal (exact float equality, as
    the builder merges them). Value v of parameter i belongs to a set of levels
    ``M_i(v)``; a point lies in the union iff ``M_1(v_1) & ... & M_n(v_n)`` is not
    empty. The count runs over the parameters carrying how many partial points
    share each intersection of levels (few distinct intersections: a value lies
    in one level, in every level or, for the general method, in every other
    level), so its cost is linear in the parameters.

    Parameters
    ----------
    values : sequence (levels) of sequences (parameters) of ndarray
        As returned by :func:`bound_value_sets` or :func:`grid_value_sets`.
    modal : sequence of float
        The modal value of every parameter.
    """
    count_levels = len(values)
    count_parameters = len(values[0])
    states: dict[int, int] = {(1 << count_levels) - 1: 1}
    modal_levels = (1 << count_levels) - 1
    for i in range(count_parameters):
        masks: defaultdict[float, int] = defaultdict(int)
        for j in range(count_levels):
            for value in set(values[j][i].tolist()):  # -0.0 and 0.0 are one key
                masks[value] |= 1 << j
        modal_levels &= masks.get(float(modal[i]), 0)
        multiplicity = Counter(masks.values())
        merged: defaultdict[int, int] = defaultdict(int)
        for state, count in states.items():
            for mask, times in multiplicity.items():
                common = state & mask
                if common:
                    merged[common] += count * times
        states = merged
    return sum(states.values()) + (0 if modal_levels else 1)
