"""Every study checks its own fuzzy method with validation runs.

After the method's runs, the study evaluates the validation points of
:func:`fuzzymbs.fuzzy.validation.validation_points` (a fifth of the method's
runs by default, at least n + 1; ``validation_runs`` sets the number, 0 turns
the check off) and compares their outputs with the retransformed cuts: the
largest excursion beyond the cut of each point's level, relative to the cut's
width, is the study's ``method_error`` (dataset attribute; per output in the
provenance; printed in summary.txt). Above ``method_tolerance`` (default 1 %)
the study warns with a :class:`~fuzzymbs.fuzzy.retransform.NonMonotonicWarning`
naming the output, the level and the parameters of the worst point. The
validation outputs are kept in the result as their own variables
(``o_validation``); they widen the bounds only when the study asks for it
(``widen_with_validation``).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fuzzymbs.fuzzy.retransform import NonMonotonicWarning
from fuzzymbs.fuzzy.validation import ValidationPoints, excursions

#: default largest method error (excursion relative to the cut's width) without a warning
DEFAULT_METHOD_TOLERANCE = 0.01


@dataclass(frozen=True)
class ValidationRuns:
    """The validation runs of a study, evaluated, and what to do with them.

    Attributes
    ----------
    points : the validation points.
    outputs : output -> (V, *shape); failed, reasons : (V,) per run.
    tolerance : the study's ``method_tolerance``; widen : ``widen_with_validation``.
    evaluated, reused : runs evaluated now and taken from the store.
    """

    points: ValidationPoints
    outputs: dict[str, np.ndarray]
    failed: np.ndarray
    reasons: np.ndarray
    tolerance: float
    widen: bool
    evaluated: int = 0
    reused: int = 0


@dataclass(frozen=True)
class MethodCheck:
    """Outcome of :func:`check_method`.

    Attributes
    ----------
    runs, failed : validation runs made and how many of them failed.
    error : largest excursion relative to the cut's width over outputs (NaN: no
        validation run could be checked).
    tolerance : the study's ``method_tolerance``.
    per_output : output -> its largest excursion.
    worst : where the largest excursion is (output, level, parameter values,
        element index), or None.
    widened : the bounds were widened with the validation outputs.
    excursion : output -> (V,) each point's largest excursion over the elements.
    """

    runs: int
    failed: int
    error: float
    tolerance: float
    per_output: dict[str, float]
    worst: dict[str, Any] | None
    widened: bool
    excursion: dict[str, np.ndarray] = field(repr=False)

    def to_attrs(self) -> dict[str, Any]:
        """Dataset attributes (NetCDF-safe numbers)."""
        return {
            "method_error": float(self.error),
            "method_tolerance": float(self.tolerance),
            "validation_runs": int(self.runs),
        }

    def to_provenance(self) -> dict[str, Any]:
        """The provenance entry ``method_check``."""
        return {
            "runs": self.runs,
            "failed": self.failed,
            "error": self.error,
            "tolerance": self.tolerance,
            "per_output": self.per_output,
            "worst": self.worst,
            "widened": self.widened,
        }


def check_method(
    names: Sequence[str],
    levels: np.ndarray,
    cuts: Mapping[str, tuple[np.ndarray, np.ndarray]],
    points: ValidationPoints,
    outputs: Mapping[str, np.ndarray],
    failed: np.ndarray,
    tolerance: float = DEFAULT_METHOD_TOLERANCE,
    widen: bool = False,
) -> MethodCheck:
    """Compare validation outputs with the method's cuts; optionally widen the cuts.

    Parameters
    ----------
    names : the plan's parameter names (columns of ``points.samples``).
    levels : (L,) the plan's levels.
    cuts : output -> ``(lower, upper)``, each (L, *shape); widened in place when
        ``widen`` (every level whose box holds the point: the point's level and
        all below, so the cuts stay nested).
    points : the validation points; outputs : output -> (V, *shape);
    failed : (V,) bool, failed validation runs (left out).
    tolerance : warn (:class:`NonMonotonicWarning`) above it.
    """
    usable = ~np.asarray(failed, dtype=bool)
    per_output: dict[str, float] = {}
    per_point: dict[str, np.ndarray] = {}
    worst: dict[str, Any] | None = None
    error = float("nan")
    for name, (lower, upper) in cuts.items():
        values = np.asarray(outputs[name], dtype=float).copy()
        values[~usable] = np.nan
        relative = excursions(lower, upper, values, points.level)
        flat = relative.reshape(len(values), -1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: failed points
            point_max = np.nanmax(flat, axis=1) if flat.shape[1] else np.full(len(values), np.nan)
        per_point[name] = point_max
        if not np.isfinite(point_max).any():
            per_output[name] = float("nan")
            continue
        best = int(np.nanargmax(point_max))
        per_output[name] = float(point_max[best])
        if not np.isfinite(error) or per_output[name] > error:
            error = per_output[name]
            element = np.unravel_index(int(np.nanargmax(flat[best])), relative.shape[1:])
            worst = {
                "output": name,
                "level": float(levels[points.level[best]]),
                "parameters": dict(zip(names, points.samples[best].tolist(), strict=True)),
                "element": [int(i) for i in element],
                "excursion": per_output[name],
            }
        if widen:
            _widen(lower, upper, values, points.level)
    result = MethodCheck(
        runs=len(points),
        failed=int(np.count_nonzero(~usable)),
        error=error,
        tolerance=float(tolerance),
        per_output=per_output,
        worst=worst,
        widened=bool(widen),
        excursion=per_point,
    )
    if worst is not None and error > tolerance:
        where = ", ".join(f"{k}={v:.6g}" for k, v in worst["parameters"].items())
        element = f" element {tuple(worst['element'])}" if worst["element"] else ""
        warnings.warn(
            f"output {worst['output']!r}{element}: a validation run at {where} lies "
            f"{error:.3g} of the cut's width outside the mu = {worst['level']:g} cut the "
            f"method found (method_tolerance {tolerance:g}): the model is not monotonic "
            "where the method assumes it, or varies between its points. Use the extended "
            "method with these parameters non-monotonic, more levels or the grid method, "
            "or widen_with_validation=True.",
            NonMonotonicWarning,
            stacklevel=3,
        )
    return result


def _widen(lower: np.ndarray, upper: np.ndarray, values: np.ndarray, level: np.ndarray) -> None:
    """Extend every cut whose box holds a point (its level and all below) to its output."""
    for row, top in enumerate(level):
        if not np.isfinite(values[row]).all():
            continue
        for j in range(int(top) + 1):
            np.minimum(lower[j : j + 1], values[row], out=lower[j : j + 1])
            np.maximum(upper[j : j + 1], values[row], out=upper[j : j + 1])
