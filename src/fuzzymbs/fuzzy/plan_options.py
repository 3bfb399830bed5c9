"""What a plan is asked for, checked: the membership levels and the fuzzy parameters.

The methods (:mod:`fuzzymbs.fuzzy.methods`), :mod:`fuzzymbs.fuzzy.transform`
(which builds plans) and :mod:`fuzzymbs.fuzzy.plan_size` (which counts their
runs before anything is built) read these, so they live below all three.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.numbers import FuzzyNumber, real_array

__all__ = ["checked_parameters", "make_levels"]


def make_levels(levels: int | ArrayLike) -> NDArray[np.float64]:
    """Membership levels ``mu_0 = 0 < ... < mu_m = 1`` from ``m`` or an explicit list.

    Parameters
    ----------
    levels : int or array_like
        ``m >= 1`` for the uniform levels ``j / m``, or an increasing sequence
        starting at 0 and ending at 1.

    Raises
    ------
    InvalidPlanError
        For m < 1, non-increasing, non-finite or wrongly bounded level lists.
    """
    if isinstance(levels, bool):
        raise InvalidPlanError(f"levels must be an int >= 1 or a list from 0 to 1, got {levels!r}")
    if isinstance(levels, int | np.integer):
        if levels < 1:
            raise InvalidPlanError(f"levels must be an int >= 1 (number of steps), got {levels!r}")
        return np.arange(int(levels) + 1, dtype=float) / int(levels)
    mus = real_array(
        levels, "levels must be an int >= 1 or a list of numbers from 0 to 1", InvalidPlanError
    )
    if mus.ndim == 0:
        raise InvalidPlanError(
            f"levels must be an int >= 1 (number of steps) or a list from 0 to 1, got "
            f"{levels!r} of type {type(levels).__name__}"
        )
    if (
        mus.ndim != 1
        or mus.size < 2
        or not np.all(np.isfinite(mus))
        or mus[0] != 0.0
        or mus[-1] != 1.0
        or np.any(np.diff(mus) <= 0.0)
    ):
        raise InvalidPlanError(
            f"levels must increase strictly from 0 to 1 (e.g. [0, 0.5, 1]), got {levels!r}"
        )
    return mus


def checked_parameters(parameters: Mapping[str, FuzzyNumber]) -> dict[str, FuzzyNumber]:
    """``parameters`` as a dict after checking it is a non-empty name -> FuzzyNumber mapping.

    Raises
    ------
    InvalidPlanError
        Not a mapping, empty, a name that is not a non-empty string, or a value
        that is not a :class:`~fuzzymbs.fuzzy.numbers.FuzzyNumber`.
    """
    if not isinstance(parameters, Mapping) or len(parameters) == 0:
        raise InvalidPlanError(
            f"parameters must be a non-empty mapping of name -> FuzzyNumber, got {parameters!r}"
        )
    for name, number in parameters.items():
        if not isinstance(name, str) or not name:
            raise InvalidPlanError(f"parameter names must be non-empty strings, got {name!r}")
        if not isinstance(number, FuzzyNumber):
            raise InvalidPlanError(
                f"parameter {name!r} must be a FuzzyNumber (e.g. Triangular), "
                f"got {type(number).__name__}"
            )
    return dict(parameters)
