"""Piecewise-linear time profiles (force histories, rotation-speed histories).

A profile is a table of knots ``(t_k, v_k)``; between knots the value is linear,
before the first and after the last knot it is held constant. The kernels also
need the running integral (a rotation angle from a speed history), which is
exact for piecewise-linear values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError


@dataclass(frozen=True, eq=False)
class TimeProfile:
    """Dimensionless multiplier ``p(t)`` given by knots.

    Parameters
    ----------
    times : array_like, shape (n,)
        Strictly increasing knot times [s].
    values : array_like, shape (n,)
        Multiplier at the knots [-].
    """

    times: NDArray[np.float64]
    values: NDArray[np.float64]

    def __init__(self, times: ArrayLike, values: ArrayLike) -> None:
        t = np.atleast_1d(np.asarray(times, dtype=float))
        v = np.atleast_1d(np.asarray(values, dtype=float))
        if t.ndim != 1 or t.shape != v.shape or t.size == 0:
            raise InvalidParameterError(
                f"TimeProfile needs 1-D times and values of equal non-zero length, got "
                f"{t.shape} and {v.shape}"
            )
        if not (np.isfinite(t).all() and np.isfinite(v).all()):
            raise InvalidParameterError("TimeProfile times and values must be finite")
        if np.any(np.diff(t) <= 0):
            raise InvalidParameterError("TimeProfile times must be strictly increasing")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    @classmethod
    def constant(cls) -> TimeProfile:
        """The profile p(t) = 1."""
        return cls([0.0], [1.0])

    @classmethod
    def ramp(cls, duration: float) -> TimeProfile:
        """0 at t = 0 rising linearly to 1 at ``duration`` [s], then held."""
        if not duration > 0:
            raise InvalidParameterError(f"ramp duration must be > 0 s, got {duration!r}")
        return cls([0.0, duration], [0.0, 1.0])

    def cumulative(self) -> NDArray[np.float64]:
        """Integral of p from the first knot to each knot [s]."""
        return np.concatenate(
            [[0.0], np.cumsum(0.5 * np.diff(self.times) * (self.values[1:] + self.values[:-1]))]
        )

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """p(t) (NumPy, for checks and plots)."""
        return np.interp(t, self.times, self.values)

    def store(self, pools) -> tuple[int, int]:
        """Knots, values and integrals into the float pool: the ``ptab`` row (start, n)."""
        start = pools.addf(self.times)
        pools.addf(self.values)
        pools.addf(self.cumulative())
        return start, int(self.times.size)


@dataclass(frozen=True)
class SpinUpProfile:
    """Kane, Ryan and Banerjee's smooth spin-up: p(t) = t/T - sin(2 pi t/T) / (2 pi) for
    t < T, then 1 -- from rest to full speed with zero acceleration at both ends, exact in
    the kernels (a turning body's driven ``Revolute`` with ``drive=SpinUp``).

    Parameters
    ----------
    duration : float
        T [s], > 0.
    """

    duration: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.duration) and self.duration > 0):
            raise InvalidParameterError(
                f"SpinUpProfile duration must be > 0 s, got {self.duration!r}"
            )

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """p(t) (NumPy, for checks and plots)."""
        x = np.asarray(t, dtype=float) / self.duration
        return np.where(x < 1.0, x - np.sin(2.0 * np.pi * x) / (2.0 * np.pi), 1.0)

    def store(self, pools) -> tuple[int, int]:
        """The duration into the float pool: the ``ptab`` row (start, -1) marks it."""
        return pools.addf([self.duration]), -1
