"""Interval arithmetic on alpha-cut bounds, level by level: the core of standard fuzzy arithmetic.

An operand is given by its bounds ``(lower, upper)``, two arrays over the same
membership levels (index 0 is the support, mu = 0). Each function returns the
bounds of the result at those levels and treats its operands as independent
intervals (Moore's interval arithmetic), which is where the dependency problem
of standard fuzzy arithmetic comes from.

This module knows nothing of fuzzy-number classes, so that
:mod:`fuzzymbs.fuzzy.numbers` can build its operators ``+ - * / **`` on it and
:mod:`fuzzymbs.fuzzy.arithmetic` can name the same operations as functions.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidFuzzyNumberError, UnsupportedOperationError

__all__ = [
    "ARITHMETIC_LEVELS",
    "Bounds",
    "add",
    "checked_exponent",
    "divide",
    "multiply",
    "negate",
    "nested",
    "power",
    "subtract",
]

#: membership levels of arithmetic results: 0, 1/40, ..., 1 (exact fractions)
ARITHMETIC_LEVELS: NDArray[np.float64] = np.arange(41, dtype=float) / 40.0

#: ``(lower, upper)`` bounds of an operand or result, one entry per membership level
Bounds = tuple[NDArray[np.float64], NDArray[np.float64]]


def add(x: Bounds, y: Bounds) -> Bounds:
    """``x + y``: ``[a_x + a_y, b_x + b_y]``."""
    (a1, b1), (a2, b2) = x, y
    return a1 + a2, b1 + b2


def subtract(x: Bounds, y: Bounds) -> Bounds:
    """``x - y``: ``[a_x - b_y, b_x - a_y]`` (``x - x`` is not 0: dependency)."""
    (a1, b1), (a2, b2) = x, y
    return a1 - b2, b1 - a2


def negate(x: Bounds) -> Bounds:
    """``-x``: ``[-b, -a]``."""
    a, b = x
    return -b, -a


def multiply(x: Bounds, y: Bounds) -> Bounds:
    """``x * y``: minimum and maximum of the four bound products."""
    (a1, b1), (a2, b2) = x, y
    products = np.stack([a1 * a2, a1 * b2, b1 * a2, b1 * b2])
    return products.min(axis=0), products.max(axis=0)


def divide(x: Bounds, y: Bounds) -> Bounds:
    """``x / y`` = ``x * [1/b_y, 1/a_y]``; the divisor's support must exclude 0.

    Raises
    ------
    InvalidFuzzyNumberError
        If the divisor's support (level 0) contains 0.
    """
    a2, b2 = y
    if a2[0] <= 0.0 <= b2[0]:
        raise InvalidFuzzyNumberError(
            f"divisor's support [{float(a2[0])!r}, {float(b2[0])!r}] contains 0; "
            "division is undefined"
        )
    return multiply(x, (1.0 / b2, 1.0 / a2))


def checked_exponent(exponent: Any) -> float:
    """``exponent`` as a finite float.

    Raises
    ------
    UnsupportedOperationError
        For a fuzzy or non-real exponent.
    InvalidFuzzyNumberError
        For NaN or an infinite exponent.
    """
    if isinstance(exponent, bool) or not isinstance(exponent, numbers.Real):
        raise UnsupportedOperationError(
            f"exponent must be a real number, got {type(exponent).__name__} "
            "(fuzzy exponents are not supported)"
        )
    p = float(exponent)
    if not math.isfinite(p):
        raise InvalidFuzzyNumberError(f"exponent must be finite, got {exponent!r}")
    return p


def power(x: Bounds, exponent: Any) -> Bounds:
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
    p = checked_exponent(exponent)
    a, b = x
    integer = p == round(p)
    if p == 0.0:
        return np.ones_like(a), np.ones_like(b)
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
    return lower, upper


def nested(lower: NDArray[np.float64], upper: NDArray[np.float64]) -> Bounds:
    """Result bounds made nested (cuts narrow as the level rises) and checked finite.

    Interval arithmetic nests exactly; this removes round-off in the last bit.

    Raises
    ------
    InvalidFuzzyNumberError
        If a bound is NaN or infinite.
    """
    lower = np.maximum.accumulate(lower)
    upper = np.minimum.accumulate(upper)
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
        raise InvalidFuzzyNumberError("fuzzy arithmetic produced a non-finite alpha-cut bound")
    return lower, upper
