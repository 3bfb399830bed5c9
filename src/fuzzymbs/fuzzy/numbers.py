"""Fuzzy numbers in the alpha-cut representation.

A fuzzy number is known to the engine only through its alpha-cuts: for a
membership level ``mu`` in [0, 1] the closed interval ``[lower, upper]`` of all
values whose membership is at least ``mu``. Cuts are nested (a higher level
gives a narrower interval), the cut at ``mu = 0`` is the support (closure of
the set with positive membership) and the cut at ``mu = 1`` is the core.

All numbers here carry the unit of the parameter they describe (SI).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from numbers import Real
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidFuzzyNumberError, UnsupportedOperationError
from fuzzymbs.fuzzy import intervals

__all__ = [
    "FuzzyNumber",
    "Gaussian",
    "PiecewiseLinear",
    "Trapezoidal",
    "Triangular",
    "check_level",
    "levelwise",
    "real_array",
    "triangular_numbers",
]


def check_level(mu: Any, what: str = "membership level mu") -> float:
    """Return ``mu`` as float after checking it is a finite number in [0, 1].

    Raises
    ------
    InvalidFuzzyNumberError
        If ``mu`` is not a real number in [0, 1].
    """
    try:
        value = float(mu)
    except (TypeError, ValueError):
        raise InvalidFuzzyNumberError(
            f"{what} must be a real number in [0, 1], got {mu!r}"
        ) from None
    if not (0.0 <= value <= 1.0):  # also rejects NaN
        raise InvalidFuzzyNumberError(f"{what} must lie in [0, 1], got {mu!r}")
    return value


def real_array(values: Any, requirement: str, error: type[Exception]) -> NDArray[np.float64]:
    """``values`` as a new float array.

    Parameters
    ----------
    values : array_like
        What the caller was given.
    requirement : str
        What ``values`` must be, phrased for the error message (e.g. "levels must be
        a list of numbers"); the message appends ``", got <values>"``.
    error : type of Exception
        Raised (from None) if ``values`` does not convert to floats.
    """
    try:
        return np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{requirement}, got {values!r}") from None


def _finite(name: str, value: Any, owner: str) -> float:
    """Convert a defining value to float, rejecting NaN, inf and non-numbers."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidFuzzyNumberError(
            f"{owner}: {name} must be a finite real number, got {value!r}"
        ) from None
    if not math.isfinite(number):
        raise InvalidFuzzyNumberError(f"{owner}: {name} must be finite, got {number!r}")
    return number


def _branch_membership(
    x: NDArray[np.float64], edge: NDArray[np.float64], levels: NDArray
) -> NDArray:
    """Membership of ``x`` on a non-decreasing piecewise-linear left branch.

    ``edge[k]`` is the lower cut bound at ``levels[k]`` (non-decreasing in k).
    Returns 0 left of ``edge[0]``, 1 from ``edge[-1]`` on, and the linear
    interpolation in between; where the branch is vertical (repeated edge
    values) the highest level is taken, so memberships are upper
    semicontinuous and ``membership(alpha_cut(mu)) >= mu``.
    """
    # index of the last edge value <= x (ties resolve to the highest level)
    k = np.searchsorted(edge, x, side="right") - 1
    result = np.zeros_like(x)
    top = k >= len(edge) - 1
    result[top] = 1.0
    inside = (k >= 0) & ~top
    ki = k[inside]
    left, right = edge[ki], edge[ki + 1]  # right > x >= left, so right > left here
    frac = (x[inside] - left) / (right - left)
    result[inside] = levels[ki] + frac * (levels[ki + 1] - levels[ki])
    return result


class FuzzyNumber(ABC):
    """Abstract fuzzy number given by its alpha-cuts.

    Subclasses implement :meth:`_cut` (the cut at a validated level) and
    :meth:`membership`; everything else follows from those.
    """

    #: value of the ``"type"`` key in :meth:`to_dict`
    kind: str = ""

    @abstractmethod
    def _cut(self, mu: float) -> tuple[float, float]:
        """Alpha-cut at an already validated level ``mu``."""

    @abstractmethod
    def membership(self, x: ArrayLike) -> NDArray[np.float64]:
        """Membership degree of every value in ``x`` (same shape as ``x``, in [0, 1])."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-able definition ``{"type": ..., <defining values>}``; inverse of from_dict."""

    def alpha_cut(self, mu: float) -> tuple[float, float]:
        """Closed interval ``(lower, upper)`` of values with membership >= ``mu``.

        Parameters
        ----------
        mu : float
            Membership level in [0, 1]; ``mu = 0`` gives the support.

        Raises
        ------
        InvalidFuzzyNumberError
            If ``mu`` is outside [0, 1] or not a number.
        """
        return self._cut(check_level(mu))

    def cuts(self, levels: ArrayLike) -> NDArray[np.float64]:
        """Alpha-cuts at several levels, shape ``(L, 2)``: column 0 lower, column 1 upper."""
        mus = np.atleast_1d(np.asarray(levels, dtype=float))
        if mus.ndim != 1:
            raise InvalidFuzzyNumberError(f"levels must be one-dimensional, got shape {mus.shape}")
        return np.array([self.alpha_cut(mu) for mu in mus], dtype=float).reshape(len(mus), 2)

    @property
    def support(self) -> tuple[float, float]:
        """Cut at ``mu = 0``."""
        return self._cut(0.0)

    @property
    def core(self) -> tuple[float, float]:
        """Cut at ``mu = 1``."""
        return self._cut(1.0)

    @property
    def modal(self) -> float:
        """Midpoint of the core (the nominal value)."""
        low, high = self.core
        return 0.5 * (low + high)

    @staticmethod
    def from_dict(data: Mapping[str, Any]) -> FuzzyNumber:
        """Rebuild a fuzzy number from :meth:`to_dict` output.

        Raises
        ------
        InvalidFuzzyNumberError
            If the type is unknown, keys are missing or extra, or values are invalid.
        """
        if not isinstance(data, Mapping) or "type" not in data:
            raise InvalidFuzzyNumberError(
                f"a fuzzy number definition must be a mapping with a 'type' key, got {data!r}"
            )
        kind = data["type"]
        classes: dict[str, type[FuzzyNumber]] = {
            cls.kind: cls for cls in (Triangular, Trapezoidal, Gaussian, PiecewiseLinear)
        }
        if kind not in classes:
            raise InvalidFuzzyNumberError(
                f"unknown fuzzy number type {kind!r}; valid types: {sorted(classes)}"
            )
        cls = classes[kind]
        arguments = {key: value for key, value in data.items() if key != "type"}
        try:
            return cls(**arguments)
        except TypeError as error:
            raise InvalidFuzzyNumberError(
                f"invalid keys for a {kind} fuzzy number: {sorted(arguments)} ({error})"
            ) from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, FuzzyNumber):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(repr(self.to_dict()))

    def __repr__(self) -> str:
        values = ", ".join(f"{k}={v!r}" for k, v in self.to_dict().items() if k != "type")
        return f"{type(self).__name__}({values})"

    # standard fuzzy arithmetic: interval arithmetic on the cuts (fuzzymbs.fuzzy.intervals)
    def __add__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.add, self, other)

    def __radd__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.add, other, self)

    def __sub__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.subtract, self, other)

    def __rsub__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.subtract, other, self)

    def __mul__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.multiply, self, other)

    def __rmul__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.multiply, other, self)

    def __truediv__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.divide, self, other, roles=DIVISION_ROLES)

    def __rtruediv__(self, other: Any) -> FuzzyNumber:
        return levelwise(intervals.divide, other, self, roles=DIVISION_ROLES)

    def __pow__(self, exponent: Any) -> FuzzyNumber:
        return levelwise(partial(intervals.power, exponent=exponent), self, roles=("base",))

    def __neg__(self) -> FuzzyNumber:
        return levelwise(intervals.negate, self)


class Triangular(FuzzyNumber):
    """Triangular fuzzy number ``TFN(lower, modal, upper)``.

    Membership rises linearly from 0 at ``lower`` to 1 at ``modal`` and falls
    to 0 at ``upper``; the cut at level mu is
    ``[lower + mu (modal - lower), upper - mu (upper - modal)]``.
    ``lower == modal == upper`` is allowed (a crisp value).

    Parameters
    ----------
    lower, modal, upper : float
        Support bounds and peak, in the parameter's unit; ``lower <= modal <= upper``.
    """

    kind = "triangular"

    def __init__(self, lower: float, modal: float, upper: float) -> None:
        owner = "Triangular"
        self.lower = _finite("lower", lower, owner)
        self._modal = _finite("modal", modal, owner)
        self.upper = _finite("upper", upper, owner)
        if not self.lower <= self._modal <= self.upper:
            raise InvalidFuzzyNumberError(
                f"Triangular needs lower <= modal <= upper, got lower={self.lower!r}, "
                f"modal={self._modal!r}, upper={self.upper!r}"
            )

    @classmethod
    def relative(cls, modal: float, spread: float) -> Triangular:
        """Symmetric triangular number ``modal * (1 -+ spread)``.

        Parameters
        ----------
        modal : float
            Peak value (parameter unit); may be negative.
        spread : float
            Relative half-width, ``0.1`` for +-10 %; must be >= 0.
        """
        owner = "Triangular.relative"
        centre = _finite("modal", modal, owner)
        relative_spread = _finite("spread", spread, owner)
        if relative_spread < 0.0:
            raise InvalidFuzzyNumberError(f"{owner}: spread must be >= 0, got {relative_spread!r}")
        half_width = abs(centre) * relative_spread
        return cls(centre - half_width, centre, centre + half_width)

    @property
    def modal(self) -> float:
        """Peak of the membership function."""
        return self._modal

    def _cut(self, mu: float) -> tuple[float, float]:
        return _linear_cut(mu, self.lower, self._modal, self._modal, self.upper)

    def membership(self, x: ArrayLike) -> NDArray[np.float64]:
        return _trapezoid_membership(x, self.lower, self._modal, self._modal, self.upper)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.kind, "lower": self.lower, "modal": self._modal, "upper": self.upper}


def triangular_numbers(triangles: Mapping[str, Sequence[float]]) -> dict[str, Triangular]:
    """Triangular fuzzy numbers from plain ``(lower, modal, upper)`` triples.

    Models state the fuzzy numbers they suggest as plain numbers (a model imports
    no part of the fuzzy engine); this turns them into numbers for a plan or a study.

    Parameters
    ----------
    triangles : mapping of str to sequence of float
        ``name -> (lower, modal, upper)``, each in its parameter's unit.

    Returns
    -------
    dict of str to Triangular
        The same names in the same order.

    Raises
    ------
    InvalidFuzzyNumberError
        A value that is not three finite numbers with ``lower <= modal <= upper``.
    """
    numbers = {}
    for name, triangle in triangles.items():
        try:
            values = tuple(triangle)
        except TypeError:
            values = ()
        if len(values) != 3:
            raise InvalidFuzzyNumberError(
                f"{name!r}: expected (lower, modal, upper), got {triangle!r}"
            )
        numbers[name] = Triangular(*values)
    return numbers


class Trapezoidal(FuzzyNumber):
    """Trapezoidal fuzzy number: support ``[lower, upper]``, core ``[core_lower, core_upper]``.

    Parameters
    ----------
    lower, core_lower, core_upper, upper : float
        Non-decreasing sequence of values in the parameter's unit.
    """

    kind = "trapezoidal"

    def __init__(self, lower: float, core_lower: float, core_upper: float, upper: float) -> None:
        owner = "Trapezoidal"
        self.lower = _finite("lower", lower, owner)
        self.core_lower = _finite("core_lower", core_lower, owner)
        self.core_upper = _finite("core_upper", core_upper, owner)
        self.upper = _finite("upper", upper, owner)
        if not self.lower <= self.core_lower <= self.core_upper <= self.upper:
            raise InvalidFuzzyNumberError(
                "Trapezoidal needs lower <= core_lower <= core_upper <= upper, got "
                f"lower={self.lower!r}, core_lower={self.core_lower!r}, "
                f"core_upper={self.core_upper!r}, upper={self.upper!r}"
            )

    def _cut(self, mu: float) -> tuple[float, float]:
        return _linear_cut(mu, self.lower, self.core_lower, self.core_upper, self.upper)

    def membership(self, x: ArrayLike) -> NDArray[np.float64]:
        return _trapezoid_membership(x, self.lower, self.core_lower, self.core_upper, self.upper)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "lower": self.lower,
            "core_lower": self.core_lower,
            "core_upper": self.core_upper,
            "upper": self.upper,
        }


def _linear_cut(
    mu: float, lower: float, core_lower: float, core_upper: float, upper: float
) -> tuple[float, float]:
    """Cut of a linear branch pair: exact at mu = 0 and 1, monotone in mu, never past the core.

    ``lower + mu (core_lower - lower)`` can round past ``core_lower``; the clamp
    keeps the cuts nested and the core exactly ``[core_lower, core_upper]``. On a
    branch only a few ulps wide it can also round back to ``lower``, whose membership
    is 0: such a bound moves towards the core until its membership is at least mu
    (:func:`_onto_level`).
    """
    if mu == 1.0:
        return core_lower, core_upper
    return (
        _onto_level(min(lower + mu * (core_lower - lower), core_lower), mu, lower, core_lower),
        _onto_level(max(upper - mu * (upper - core_upper), core_upper), mu, upper, core_upper),
    )


def _onto_level(bound: float, mu: float, start: float, core: float) -> float:
    """``bound`` moved ulp by ulp towards ``core`` while its membership on the branch
    from ``start`` (0) to ``core`` (1) is below mu by more than round-off (1e-9). Only a
    branch narrower than about 5e8 ulps of its values can fall short by that much, and
    one ulp then adds more than the shortfall: at most two steps."""
    width = core - start
    if width == 0.0:
        return bound
    while (bound - start) / width < mu - 1e-9 and bound != core:
        bound = float(np.nextafter(bound, core))
    return bound


def _trapezoid_membership(
    x: ArrayLike, lower: float, core_lower: float, core_upper: float, upper: float
) -> NDArray[np.float64]:
    """Membership of a (possibly degenerate) trapezoid, upper semicontinuous at jumps."""
    values = np.asarray(x, dtype=float)
    levels = np.array([0.0, 1.0])
    flat = values.reshape(-1)
    left = _branch_membership(flat, np.array([lower, core_lower]), levels)
    right = _branch_membership(-flat, np.array([-upper, -core_upper]), levels)
    result = np.minimum(left, right)
    result[np.isnan(flat)] = np.nan
    return result.reshape(values.shape)


class Gaussian(FuzzyNumber):
    """Truncated Gaussian fuzzy number.

    Membership ``(exp(-(x - mean)^2 / (2 std^2)) - e_t) / (1 - e_t)`` inside
    ``mean +- truncation * std`` and 0 outside, with ``e_t = exp(-truncation^2/2)``:
    the bell curve lifted so that it reaches 0 exactly at the truncation. The cut
    at level mu is ``mean +- std * sqrt(-2 ln(e_t + mu (1 - e_t)))``.

    Parameters
    ----------
    mean : float
        Peak value (parameter unit).
    std : float
        Width of the bell (parameter unit), > 0.
    truncation : float, default 3.0
        Support half-width in units of ``std``, > 0.
    """

    kind = "gaussian"

    def __init__(self, mean: float, std: float, truncation: float = 3.0) -> None:
        owner = "Gaussian"
        self.mean = _finite("mean", mean, owner)
        self.std = _finite("std", std, owner)
        self.truncation = _finite("truncation", truncation, owner)
        if self.std <= 0.0:
            raise InvalidFuzzyNumberError(f"Gaussian: std must be > 0, got {self.std!r}")
        if self.truncation <= 0.0:
            raise InvalidFuzzyNumberError(
                f"Gaussian: truncation must be > 0, got {self.truncation!r}"
            )
        self._floor = math.exp(-0.5 * self.truncation**2)

    def _cut(self, mu: float) -> tuple[float, float]:
        if mu == 0.0:  # exact support, no round-off through exp/log
            half_width = self.truncation * self.std
        else:
            level = self._floor + mu * (1.0 - self._floor)
            half_width = self.std * math.sqrt(max(-2.0 * math.log(level), 0.0))
        return self.mean - half_width, self.mean + half_width

    def membership(self, x: ArrayLike) -> NDArray[np.float64]:
        values = np.asarray(x, dtype=float)
        offset = (values - self.mean) / self.std
        bell = (np.exp(-0.5 * offset**2) - self._floor) / (1.0 - self._floor)
        inside = np.abs(offset) <= self.truncation
        return np.where(np.isnan(values), np.nan, np.where(inside, np.clip(bell, 0.0, 1.0), 0.0))

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "mean": self.mean,
            "std": self.std,
            "truncation": self.truncation,
        }


class PiecewiseLinear(FuzzyNumber):
    """Fuzzy number from explicit nested alpha-cuts, linear in mu between them.

    Parameters
    ----------
    levels : array_like, shape (L,)
        Strictly increasing membership levels, first 0, last 1.
    lower, upper : array_like, shape (L,)
        Cut bounds at those levels: ``lower`` non-decreasing, ``upper``
        non-increasing and ``lower <= upper`` (nested cuts).
    """

    kind = "piecewise_linear"

    def __init__(self, levels: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> None:
        owner = "PiecewiseLinear"
        arrays = {}
        for name, values in (("levels", levels), ("lower", lower), ("upper", upper)):
            array = real_array(
                values,
                f"{owner}: {name} must be a sequence of real numbers",
                InvalidFuzzyNumberError,
            )
            if array.ndim != 1 or array.size < 2:
                raise InvalidFuzzyNumberError(
                    f"{owner}: {name} must be one-dimensional with at least 2 entries "
                    f"(levels 0 and 1), got shape {array.shape}"
                )
            bad = ~np.isfinite(array)
            if bad.any():
                raise InvalidFuzzyNumberError(
                    f"{owner}: {name} must be finite, got {float(array[bad][0])!r} at index "
                    f"{int(np.flatnonzero(bad)[0])}"
                )
            arrays[name] = array
        mus, low, high = arrays["levels"], arrays["lower"], arrays["upper"]
        if not (len(mus) == len(low) == len(high)):
            raise InvalidFuzzyNumberError(
                f"{owner}: levels, lower and upper must have equal length, got "
                f"{len(mus)}, {len(low)}, {len(high)}"
            )
        if mus[0] != 0.0 or mus[-1] != 1.0 or np.any(np.diff(mus) <= 0.0):
            raise InvalidFuzzyNumberError(
                f"{owner}: levels must increase strictly from 0 to 1, got {mus.tolist()}"
            )
        for name, step in (("lower", np.diff(low)), ("upper", -np.diff(high))):
            if np.any(step < 0.0):
                index = int(np.flatnonzero(step < 0.0)[0])
                raise InvalidFuzzyNumberError(
                    f"{owner}: cuts are not nested: {name} at level {float(mus[index + 1])!r} "
                    f"({float(arrays[name][index + 1])!r}) lies outside the cut at level "
                    f"{float(mus[index])!r} ({float(arrays[name][index])!r})"
                )
        if np.any(low > high):
            index = int(np.flatnonzero(low > high)[0])
            raise InvalidFuzzyNumberError(
                f"{owner}: lower {float(low[index])!r} > upper {float(high[index])!r} "
                f"at level {float(mus[index])!r}"
            )
        self.levels, self.lower, self.upper = mus, low, high
        for array in (mus, low, high):
            array.setflags(write=False)

    def _cut(self, mu: float) -> tuple[float, float]:
        return (
            float(np.interp(mu, self.levels, self.lower)),
            float(np.interp(mu, self.levels, self.upper)),
        )

    def membership(self, x: ArrayLike) -> NDArray[np.float64]:
        values = np.asarray(x, dtype=float)
        flat = values.reshape(-1)
        left = _branch_membership(flat, self.lower, self.levels)
        right = _branch_membership(-flat, -self.upper, self.levels)
        result = np.minimum(left, right)
        result[np.isnan(flat)] = np.nan
        return result.reshape(values.shape)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "levels": self.levels.tolist(),
            "lower": self.lower.tolist(),
            "upper": self.upper.tolist(),
        }


# ------------------------------------------------------------ standard arithmetic

#: roles of the operands of a division, as error messages name them
DIVISION_ROLES = ("left operand", "divisor")


def _result_levels(operands: Sequence[Any]) -> NDArray[np.float64]:
    levels = [intervals.ARITHMETIC_LEVELS]
    levels += [x.levels for x in operands if isinstance(x, PiecewiseLinear)]
    return np.unique(np.concatenate(levels))


def _operand_bounds(operand: Any, levels: NDArray[np.float64], role: str) -> intervals.Bounds:
    """(lower, upper) arrays of an operand at ``levels``; a real scalar is a crisp number."""
    if isinstance(operand, FuzzyNumber):
        cuts = operand.cuts(levels)
        return cuts[:, 0], cuts[:, 1]
    if isinstance(operand, Real) and not isinstance(operand, bool):
        value = float(operand)
        if not math.isfinite(value):
            raise InvalidFuzzyNumberError(f"{role} must be finite, got {value!r}")
        return np.full(len(levels), value), np.full(len(levels), value)
    raise UnsupportedOperationError(
        f"{role} must be a FuzzyNumber or a real number, got {type(operand).__name__}"
    )


def levelwise(
    operation: Callable[..., intervals.Bounds],
    *operands: Any,
    roles: Sequence[str] | None = None,
) -> PiecewiseLinear:
    """Standard fuzzy arithmetic: an interval operation applied to the cuts, level by level.

    Parameters
    ----------
    operation : callable
        ``operation(bounds, ...) -> (lower, upper)`` taking one ``(lower, upper)``
        pair of arrays per operand (see :mod:`fuzzymbs.fuzzy.intervals`).
    *operands : FuzzyNumber or real
        The operands, treated as independent; a finite real number is crisp.
    roles : sequence of str, optional
        What error messages call each operand; default ``("operand",)`` for one
        operand and ``("left operand", "right operand")`` for two.

    Returns
    -------
    PiecewiseLinear
        The result at :data:`~fuzzymbs.fuzzy.intervals.ARITHMETIC_LEVELS` plus the
        levels of every piecewise-linear operand: exact there, linear in mu between.

    Raises
    ------
    UnsupportedOperationError
        For an operand that is neither a fuzzy number nor a real number.
    InvalidFuzzyNumberError
        For a non-finite real operand or a non-finite result.
    """
    if roles is None:
        roles = ("operand",) if len(operands) == 1 else ("left operand", "right operand")
    levels = _result_levels(operands)
    bounds = [_operand_bounds(x, levels, role) for x, role in zip(operands, roles, strict=True)]
    return PiecewiseLinear(levels, *intervals.nested(*operation(*bounds)))
