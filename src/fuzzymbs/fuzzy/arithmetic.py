"""Standard fuzzy arithmetic: level-wise interval arithmetic on alpha-cuts.

Kept for comparison with the transformation method, not for analysis. Each
operation treats its operands as independent, so whenever a parameter occurs
more than once in an expression the result overestimates (the dependency
problem): for ``x = Triangular(-1, 0, 1)``, ``x - x`` gives ``[-2, 2]`` at
mu = 0 instead of ``0``, and ``x * x`` gives ``[-1, 1]`` instead of
``[0, 1]``. (``x ** 2`` is an elementary function of one operand and is exact.)
Results are :class:`~fuzzymbs.fuzzy.numbers.PiecewiseLinear` numbers on a
fixed level set (:data:`ARITHMETIC_LEVELS`, plus the levels of any
piecewise-linear operand); exact at those levels, linear in mu between them.

The interval operations themselves live in :mod:`fuzzymbs.fuzzy.intervals`;
:func:`fuzzymbs.fuzzy.numbers.levelwise` applies them to the cuts (the fuzzy
numbers' operators ``+ - * / **`` use the same two pieces).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidFuzzyNumberError, UnsupportedOperationError
from fuzzymbs.fuzzy import intervals
from fuzzymbs.fuzzy.intervals import ARITHMETIC_LEVELS
from fuzzymbs.fuzzy.numbers import DIVISION_ROLES, FuzzyNumber, PiecewiseLinear, levelwise

__all__ = [
    "ARITHMETIC_LEVELS",
    "add",
    "apply_monotone",
    "divide",
    "multiply",
    "negate",
    "power",
    "subtract",
]


def add(x: Any, y: Any) -> PiecewiseLinear:
    """``x + y`` cut by cut: ``[a_x + a_y, b_x + b_y]``."""
    return levelwise(intervals.add, x, y)


def subtract(x: Any, y: Any) -> PiecewiseLinear:
    """``x - y`` cut by cut: ``[a_x - b_y, b_x - a_y]`` (``x - x`` is not 0: dependency)."""
    return levelwise(intervals.subtract, x, y)


def negate(x: Any) -> PiecewiseLinear:
    """``-x``: ``[-b, -a]``."""
    return levelwise(intervals.negate, x)


def multiply(x: Any, y: Any) -> PiecewiseLinear:
    """``x * y`` cut by cut: min and max of the four bound products."""
    return levelwise(intervals.multiply, x, y)


def divide(x: Any, y: Any) -> PiecewiseLinear:
    """``x / y`` = ``x * [1/b_y, 1/a_y]``; the divisor's support must exclude 0.

    Raises
    ------
    InvalidFuzzyNumberError
        If the divisor's support contains 0.
    """
    return levelwise(intervals.divide, x, y, roles=DIVISION_ROLES)


def power(x: Any, exponent: Any) -> PiecewiseLinear:
    """``x ** exponent`` for a real exponent: exact, as a function of one operand.

    Which bases each exponent accepts, and the errors otherwise: see
    :func:`fuzzymbs.fuzzy.intervals.power`.
    """
    # the exponent is checked before the base, as its error is the more telling one
    p = intervals.checked_exponent(exponent)
    return levelwise(partial(intervals.power, exponent=p), x, roles=("base",))


def apply_monotone(
    func: Callable[[NDArray[np.float64]], Any], x: FuzzyNumber, increasing: bool = True
) -> PiecewiseLinear:
    """Image of ``x`` under a monotonic function, cut by cut: ``[f(a), f(b)]`` (or swapped).

    Exact for functions that really are monotonic on the support of ``x``;
    the caller vouches for that.

    Parameters
    ----------
    func : callable
        Vectorised function of an array of parameter values.
    x : FuzzyNumber
        Argument.
    increasing : bool
        True for non-decreasing ``func``, False for non-increasing.
    """
    if not isinstance(x, FuzzyNumber):
        raise UnsupportedOperationError(
            f"apply_monotone needs a FuzzyNumber argument, got {type(x).__name__}"
        )

    def image(bounds: intervals.Bounds) -> intervals.Bounds:
        a, b = bounds
        f_a = np.asarray(func(a), dtype=float).reshape(a.shape)
        f_b = np.asarray(func(b), dtype=float).reshape(b.shape)
        lower, upper = (f_a, f_b) if increasing else (f_b, f_a)
        if np.any(lower > upper):
            raise InvalidFuzzyNumberError(
                f"func is not {'increasing' if increasing else 'decreasing'} on the support "
                f"of {x!r}"
            )
        return lower, upper

    return levelwise(image, x, roles=("argument",))
