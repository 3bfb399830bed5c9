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
"""

from __future__ import annotations

import math
import numbers as _numbers
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidFuzzyNumberError, UnsupportedOperationError
from fuzzymbs.fuzzy.numbers import FuzzyNumber, PiecewiseLinear

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

#: membership levels of arithmetic results: 0, 1/40, ..., 1 (exact fractions)
ARITHMETIC_LEVELS: NDArray[np.float64] = np.arange(41, dtype=float) / 40.0


def _result_levels(*operands: Any) -> NDArray[np.float64]:
    levels = [ARITHMETIC_LEVELS]
    levels += [x.levels for x in operands if isinstance(x, PiecewiseLinear)]
    return np.unique(np.concatenate(levels))


def _cuts(operand: Any, levels: NDArray[np.float64], role: str) -> tuple[NDArray, NDArray]:
    """(lower, upper) arrays of an operand at ``levels``; a real scalar is a crisp number."""
    if isinstance(operand, FuzzyNumber):
        cuts = operand.cuts(levels)
        return cuts[:, 0], cuts[:, 1]
    if isinstance(operand, _numbers.Real) and not isinstance(operand, bool):
        value = float(operand)
        if not math.isfinite(value):
            raise InvalidFuzzyNumberError(f"{role} must be finite, got {operand!r}")
        return np.full(len(levels), value), np.full(len(levels), value)
    raise UnsupportedOperationError(
        f"{role} must be a FuzzyNumber or a real number, got {type(operand).__name__}"
    )


def _result(levels: NDArray, lower: NDArray, upper: NDArray) -> PiecewiseLinear:
    # interval arithmetic nests exactly; enforce it against round-off in the last bit
    lower = np.maximum.accumulate(lower)
    upper = np.minimum.accumulate(upper)
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise InvalidFuzzyNumberError("fuzzy arithmetic produced a non-finite alpha-cut bound")
    return PiecewiseLinear(levels, lower, upper)


def add(x: Any, y: Any) -> PiecewiseLinear:
    """``x + y`` cut by cut: ``[a_x + a_y, b_x + b_y]``."""
    levels = _result_levels(x, y)
    (a1, b1), (a2, b2) = _cuts(x, levels, "left operand"), _cuts(y, levels, "right operand")
    return _result(levels, a1 + a2, b1 + b2)


def subtract(x: Any, y: Any) -> PiecewiseLinear:
    """``x - y`` cut by cut: ``[a_x - b_y, b_x - a_y]`` (``x - x`` is not 0: dependency)."""
    levels = _result_levels(x, y)
    (a1, b1), (a2, b2) = _cuts(x, levels, "left operand"), _cuts(y, levels, "right operand")
    return _result(levels, a1 - b2, b1 - a2)


def negate(x: Any) -> PiecewiseLinear:
    """``-x``: ``[-b, -a]``."""
    levels = _result_levels(x)
    a, b = _cuts(x, levels, "operand")
    return _result(levels, -b, -a)


def multiply(x: Any, y: Any) -> PiecewiseLinear:
    """``x * y`` cut by cut: min and max of the four bound products."""
    levels = _result_levels(x, y)
    (a1, b1), (a2, b2) = _cuts(x, levels, "left operand"), _cuts(y, levels, "right operand")
    products = np.stack([a1 * a2, a1 * b2, b1 * a2, b1 * b2])
    return _result(levels, products.min(axis=0), products.max(axis=0))


def divide(x: Any, y: Any) -> PiecewiseLinear:
    """``x / y`` = ``x * [1/b_y, 1/a_y]``; the divisor's support must exclude 0.

    Raises
    ------
    InvalidFuzzyNumberError
        If the divisor's support contains 0.
    """
    levels = _result_levels(x, y)
    a2, b2 = _cuts(y, levels, "divisor")
    if a2[0] <= 0.0 <= b2[0]:
        raise InvalidFuzzyNumberError(
            f"divisor's support [{a2[0]!r}, {b2[0]!r}] contains 0; division is undefined"
        )
    reciprocal = PiecewiseLinear(levels, 1.0 / b2, 1.0 / a2)
    return multiply(x, reciprocal)


def power(x: Any, exponent: Any) -> PiecewiseLinear:
    """``x ** exponent`` for a real exponent, as a function of one operand (exact).

    Integer exponents accept any base (an even power of a cut containing 0
    starts at 0); negative integers need a support without 0; non-integer
    exponents need a support >= 0 (> 0 for negative exponents).

    Raises
    ------
    UnsupportedOperationError
        For a fuzzy or non-real exponent.
    InvalidFuzzyNumberError
        If the base's support is outside the exponent's domain.
    """
    if isinstance(exponent, bool) or not isinstance(exponent, _numbers.Real):
        raise UnsupportedOperationError(
            f"exponent must be a real number, got {type(exponent).__name__} "
            "(fuzzy exponents are not supported)"
        )
    p = float(exponent)
    if not math.isfinite(p):
        raise InvalidFuzzyNumberError(f"exponent must be finite, got {exponent!r}")
    levels = _result_levels(x)
    a, b = _cuts(x, levels, "base")
    integer = p == round(p)
    if p == 0.0:
        return _result(levels, np.ones_like(a), np.ones_like(b))
    if p < 0.0 and a[0] <= 0.0 <= b[0]:
        raise InvalidFuzzyNumberError(
            f"base support [{a[0]!r}, {b[0]!r}] contains 0; a negative power is undefined"
        )
    if not integer and a[0] < 0.0:
        raise InvalidFuzzyNumberError(
            f"base support [{a[0]!r}, {b[0]!r}] has negative values; a non-integer power "
            f"{p!r} needs a base >= 0"
        )
    low, high = a**p, b**p
    lower, upper = np.minimum(low, high), np.maximum(low, high)
    if integer and int(p) % 2 == 0:
        # an even power has its minimum 0 inside a cut that contains 0
        lower = np.where((a <= 0.0) & (b >= 0.0), 0.0, lower)
    return _result(levels, lower, upper)


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
    levels = _result_levels(x)
    a, b = _cuts(x, levels, "argument")
    f_a = np.asarray(func(a), dtype=float).reshape(a.shape)
    f_b = np.asarray(func(b), dtype=float).reshape(b.shape)
    lower, upper = (f_a, f_b) if increasing else (f_b, f_a)
    if np.any(lower > upper):
        raise InvalidFuzzyNumberError(
            f"func is not {'increasing' if increasing else 'decreasing'} on the support of {x!r}"
        )
    return _result(levels, lower, upper)
