"""What a plan is asked for, checked: the membership levels, the fuzzy parameters, and
the sparse method's defaults and the limit of its search.

The methods (:mod:`fuzzymbs.fuzzy.methods`), :mod:`fuzzymbs.fuzzy.transform`
(which builds plans) and :mod:`fuzzymbs.fuzzy.plan_size` (which counts their
runs before anything is built) read these, so they live below all three.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.numbers import FuzzyNumber, real_array

__all__ = [
    "DEFAULT_SEARCH_POINTS",
    "DEFAULT_SPARSE_LEVEL",
    "MAX_SEARCH_POINTS",
    "check_sparse_search",
    "checked_parameters",
    "make_levels",
]

#: default ``sparse_level`` (Smolyak's q = n + 3: exact for polynomials of total degree 3)
DEFAULT_SPARSE_LEVEL = 3
#: default number of search points per cut box of a sparse plan (at least 3^n are used)
DEFAULT_SEARCH_POINTS = 20_000
#: the most search points per cut box a sparse plan's retransformation evaluates: 3^15, the
#: tensor grid of 15 parameters (1.7 GB of points per cut box before the interpolant runs)
MAX_SEARCH_POINTS = 3**15


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


def check_sparse_search(count_parameters: int) -> None:
    """Refuse a sparse retransformation whose search grid per cut box cannot be evaluated.

    The search needs at least 3 points per parameter in every cut box, ``3^n``
    in all; beyond :data:`MAX_SEARCH_POINTS` (n > 15) it cannot run, so a study
    refuses such a plan before evaluating any sample, and a plan's
    retransformation refuses it instead of running out of memory. The plan itself
    (its samples, its interpolant) has no such limit.

    Raises
    ------
    InvalidPlanError
        ``3^n`` above :data:`MAX_SEARCH_POINTS`.
    """
    if count_parameters <= 15:  # 3^15 = MAX_SEARCH_POINTS; no huge power for large n
        return
    digits = int(count_parameters * math.log10(3.0))
    raise InvalidPlanError(
        f"the sparse method finds every cut's bounds by searching its interpolant on a "
        f"tensor grid of at least 3 points per parameter: 3^{count_parameters} (about "
        f"1e{digits}) points per cut box for {count_parameters} fuzzy parameters, more than "
        f"the {MAX_SEARCH_POINTS:,} (3^15) it can evaluate: the sparse method serves at "
        f"most 15 fuzzy parameters"
    )
