"""Screening for non-monotonic parameters (input to the extended transformation method).

The extended method needs to know which parameters the model is not monotonic
in. The screening evaluates the model along each parameter's own axis through
the all-modal point and looks at the shape of every output element there:

* :func:`screening_samples` -- for parameter i, the points whose coordinate i
  takes every alpha-cut bound (lower and upper at every membership level) and
  the modal value, with every other parameter at its modal value (the
  all-modal point of :class:`~fuzzymbs.fuzzy.transform.Plan`: the midpoint of
  the core, also for trapezoidal numbers). The all-modal point is shared by
  all axes, so n parameters with m level steps need at most ``n * 2 m + 1``
  runs (triangular numbers: exactly that).
* :func:`nonmonotonic_parameters` -- along each axis, sorted by parameter
  value, an output element is monotonic if its consecutive differences never
  change sign; differences no larger than ``rtol`` times the element's range
  over all screening points (or ``roundoff`` times its magnitude) are ignored,
  so flat responses and round-off do not count. A parameter is non-monotonic
  if any element of any output is.

Limits (also in docs/fuzzy.md): only the axes through the modal point are
seen. A model that is monotonic along those axes but not elsewhere in the
cut box (an interaction such as ``(x1 - 2) x2`` with x2's cut containing 0, or
a peak that moves with another parameter) is not detected, and a reversal
between two neighbouring cut bounds is not resolved. The retransformation's
:class:`~fuzzymbs.fuzzy.transform.NonMonotonicWarning` remains the check
after the fact.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import IncompleteResultError, InvalidPlanError, ModelOutputError
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import checked_parameters, make_levels

__all__ = [
    "DEFAULT_ROUNDOFF",
    "DEFAULT_RTOL",
    "Screening",
    "ScreeningWarning",
    "check_tolerance",
    "nonmonotonic_parameters",
    "screening_samples",
]

#: reversals up to this fraction of an element's range over all screening points are ignored
DEFAULT_RTOL = 1e-6
#: differences up to this fraction of an element's magnitude are round-off
DEFAULT_ROUNDOFF = 1e-12


class ScreeningWarning(UserWarning):
    """Screening samples failed and were left out of the monotonicity decision."""


class Screening(NamedTuple):
    """Sample points of a monotonicity screening (see :func:`screening_samples`).

    Attributes
    ----------
    names : tuple of str
        Parameter names, in the order of the ``samples`` columns.
    samples : ndarray, shape (k, n)
        Unique points; row 0 is the all-modal point.
    axes : tuple of ndarray of int
        ``axes[i]``: rows of ``samples`` on parameter i's axis (the modal point
        included), sorted by increasing value of parameter i.
    """

    names: tuple[str, ...]
    samples: NDArray[np.float64]
    axes: tuple[NDArray[np.intp], ...]


def screening_samples(
    parameters: Mapping[str, FuzzyNumber], levels: int | ArrayLike = 4
) -> Screening:
    """Points along every parameter's axis through the all-modal point.

    Parameters
    ----------
    parameters : mapping of str to FuzzyNumber
        Fuzzy parameters by name (their order fixes the columns).
    levels : int or array_like
        ``m`` for mu_j = j/m, or an increasing list from 0 to 1 (as for :func:`plan`).

    Returns
    -------
    Screening
        ``(names, samples, axes)``: parameter i's axis holds the distinct values
        of its cut bounds at every level and its modal value (others modal).

    Raises
    ------
    InvalidPlanError
        Bad levels, or parameters that are not a non-empty mapping of fuzzy numbers.

    Examples
    --------
    >>> from fuzzymbs.fuzzy.numbers import Triangular
    >>> s = screening_samples({"a": Triangular(1, 2, 3), "b": Triangular(4, 5, 6)}, levels=2)
    >>> s.samples.shape   # 1 modal point + 2 parameters x 4 cut bounds
    (9, 2)
    """
    numbers = checked_parameters(parameters)
    mus = make_levels(levels)
    names = tuple(numbers)
    modal = np.array([number.modal for number in numbers.values()])
    rows: list[NDArray[np.float64]] = [modal]
    axes: list[NDArray[np.intp]] = []
    for i, number in enumerate(numbers.values()):
        cuts = number.cuts(mus)
        # np.unique sorts and merges equal values (also -0.0 and 0.0)
        values = np.unique(np.concatenate((cuts.ravel(), [modal[i]])))
        axis = np.empty(len(values), dtype=np.intp)
        for position, value in enumerate(values):
            if value == modal[i]:
                axis[position] = 0
                continue
            point = modal.copy()
            point[i] = value
            axis[position] = len(rows)
            rows.append(point)
        axes.append(axis)
    samples = np.array(rows)
    samples.setflags(write=False)
    return Screening(names, samples, tuple(axes))


def _checked_outputs(
    screening: Screening, outputs: Mapping[str, ArrayLike]
) -> dict[str, NDArray[np.float64]]:
    count = len(screening.samples)
    if not isinstance(outputs, Mapping) or not outputs:
        raise ModelOutputError(
            "outputs must be a non-empty dict {output name: ndarray (k, ...)}, got "
            f"{type(outputs).__name__}"
        )
    checked = {}
    for name, value in outputs.items():
        array = np.asarray(value)
        if array.ndim == 0 or array.shape[0] != count:
            raise ModelOutputError(
                f"output {name!r} must have leading axis k={count} (one row per screening "
                f"sample), got shape {array.shape}"
            )
        if not (np.issubdtype(array.dtype, np.number) or array.dtype == np.bool_):
            raise ModelOutputError(f"output {name!r} must be numeric, got dtype {array.dtype}")
        if np.iscomplexobj(array):
            raise ModelOutputError(f"output {name!r} is complex; give real quantities")
        checked[str(name)] = array.astype(float, copy=False).reshape(count, -1)
    return checked


def check_tolerance(name: str, value: Any) -> float:
    """``value`` as a float after checking it is a finite number >= 0.

    Parameters
    ----------
    name : str
        What the value is (e.g. ``"rtol"``), for the error message.
    value : int or float
        A relative tolerance [-].

    Raises
    ------
    InvalidPlanError
        For a bool, a non-number, NaN, inf or a negative value.
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise InvalidPlanError(f"{name} must be a number >= 0, got {value!r}")
    if not math.isfinite(float(value)) or value < 0:
        raise InvalidPlanError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def nonmonotonic_parameters(
    screening: Screening,
    outputs: Mapping[str, ArrayLike],
    rtol: float = DEFAULT_RTOL,
    *,
    failed: ArrayLike | None = None,
    roundoff: float = DEFAULT_ROUNDOFF,
) -> dict[str, Any]:
    """Decide from screening outputs which parameters the model is not monotonic in.

    Parameters
    ----------
    screening : Screening
        From :func:`screening_samples`.
    outputs : mapping of str to array_like (k, ...)
        Model outputs at ``screening.samples``, any trailing shape (time, nodes, ...).
    rtol : float
        A difference between neighbouring axis points counts only if it exceeds
        ``rtol`` times the element's range (max - min over all screening points).
    failed : array_like of bool, shape (k,), optional
        Samples whose run failed. Samples with a NaN or inf in any output are
        treated as failed as well. Failed samples are left out (with a
        :class:`ScreeningWarning`); they are listed in the report.
    roundoff : float
        Differences up to ``roundoff`` times the element's largest magnitude
        are also ignored (round-off of an otherwise flat response).

    Returns
    -------
    dict
        JSON-able report::

            {"nonmonotonic": [names, in parameter order],
             "runs": k, "rtol": rtol, "roundoff": roundoff,
             "excluded_samples": [failed sample rows],
             "parameters": {name: {
                 "nonmonotonic": bool,
                 "points": valid axis points, "excluded_points": failed axis points,
                 "elements": number of non-monotonic output elements,
                 "violation": worst reversal / element range (0.0 if monotonic),
                 "output": output of the worst element (None if monotonic),
                 "index": its index in the output's trailing shape (list; [] for scalars)}}}

        The reversal of an element is ``min(largest fall after a rise, largest
        rise after a fall)`` along the sorted axis: how far the response turns back.

    Raises
    ------
    ModelOutputError
        Outputs that are not numeric arrays with leading axis k.
    IncompleteResultError
        A parameter's axis lost points to failed samples and keeps fewer than 3,
        so its monotonicity cannot be judged.
    InvalidPlanError
        A bad tolerance or ``failed`` mask.
    """
    rtol = check_tolerance("rtol", rtol)
    roundoff = check_tolerance("roundoff", roundoff)
    values = _checked_outputs(screening, outputs)
    count = len(screening.samples)
    if failed is None:
        mask = np.zeros(count, dtype=bool)
    else:
        mask = np.asarray(failed)
        if mask.shape != (count,) or mask.dtype != np.bool_:
            raise InvalidPlanError(
                f"failed must be a bool array of shape ({count},), got dtype {mask.dtype} "
                f"and shape {mask.shape}"
            )
        mask = mask.copy()
    for flat in values.values():
        mask |= ~np.isfinite(flat).all(axis=1)
    valid = ~mask
    if not valid.any():
        raise IncompleteResultError(f"all {count} screening samples failed; nothing to judge")

    # per element: range and magnitude over every valid screening point -> tolerance
    tolerance = {}
    ranges = {}
    for name, flat in values.items():
        good = flat[valid]
        spread = good.max(axis=0) - good.min(axis=0)
        magnitude = np.abs(good).max(axis=0)
        ranges[name] = spread
        tolerance[name] = np.maximum(rtol * spread, roundoff * magnitude)

    excluded = np.flatnonzero(mask)
    if excluded.size:
        warnings.warn(
            f"{excluded.size} of {count} screening samples failed and are left out of the "
            f"monotonicity decision (rows {excluded.tolist()}); a reversal at those points "
            "is not seen",
            ScreeningWarning,
            stacklevel=2,
        )
    report_parameters: dict[str, dict[str, Any]] = {}
    for name, axis in zip(screening.names, screening.axes, strict=True):
        rows = axis[valid[axis]]
        lost = len(axis) - len(rows)
        if lost and len(rows) < 3:
            raise IncompleteResultError(
                f"screening of parameter {name!r}: {lost} of its {len(axis)} axis points "
                f"failed (rows {axis[~valid[axis]].tolist()}), leaving {len(rows)}; at least "
                "3 are needed to judge monotonicity. Fix the failing runs or name the "
                "non-monotonic parameters explicitly."
            )
        entry: dict[str, Any] = {
            "nonmonotonic": False,
            "points": len(rows),
            "excluded_points": lost,
            "elements": 0,
            "violation": 0.0,
            "output": None,
            "index": None,
        }
        for output, flat in values.items():
            along = flat[rows]  # sorted by parameter value
            steps = np.diff(along, axis=0)
            limit = tolerance[output]
            rises = (steps > limit).any(axis=0)
            falls = (steps < -limit).any(axis=0)
            reversing = rises & falls
            if not reversing.any():
                continue
            columns = np.flatnonzero(reversing)
            part = along[:, columns]
            fall = (np.maximum.accumulate(part, axis=0) - part).max(axis=0)
            rise = (part - np.minimum.accumulate(part, axis=0)).max(axis=0)
            # a reversing element has two significant steps, so its range is > 0
            relative = np.minimum(fall, rise) / ranges[output][columns]
            worst = int(np.argmax(relative))
            entry["nonmonotonic"] = True
            entry["elements"] += int(columns.size)
            if relative[worst] > entry["violation"]:
                shape = np.asarray(outputs[output]).shape[1:]
                entry["violation"] = float(relative[worst])
                entry["output"] = output
                entry["index"] = [int(i) for i in np.unravel_index(columns[worst], shape)]
        report_parameters[name] = entry
    return {
        "nonmonotonic": [
            name for name in screening.names if report_parameters[name]["nonmonotonic"]
        ],
        "runs": count,
        "rtol": rtol,
        "roundoff": roundoff,
        "excluded_samples": excluded.tolist(),
        "parameters": report_parameters,
    }
