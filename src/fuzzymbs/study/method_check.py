"""Every study checks its own fuzzy method with validation runs.

After the method's runs, the study evaluates the validation runs of
:class:`fuzzymbs.fuzzy.validation.MethodSearch` in rounds (a fifth of the method's
runs by default, at least 12 per parameter; ``validation_runs`` sets the number, 0
turns the check off), reduced as they arrive, and compares their range with the
retransformed cuts: the largest part of it outside a level's cut, on the cut-width
scale, is the study's ``method_error`` (dataset attribute; per output in the
provenance; printed in summary.txt). The runs are a sample, so it is a lower bound
(``method_error_bound = "lower"``): the method misses at least that much, possibly
more, and a result within the tolerance says only that no run found a larger miss.
Above ``method_tolerance`` (default 1 %)
the study warns with a :class:`~fuzzymbs.fuzzy.retransform.NonMonotonicWarning`
naming the output, the level and the parameters of the worst point. Each run's
excursion is kept in the result (``o_validation_excursion``), the runs' outputs
(``o_validation``) where the plan's raw outputs are; they widen the bounds only
when the study asks for it (``widen_with_validation``).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fuzzymbs.fuzzy.band_scale import LOWER_BOUND
from fuzzymbs.fuzzy.retransform import NonMonotonicWarning
from fuzzymbs.fuzzy.validation import SearchOutcome, ValidationPoints

#: default largest method error (excursion relative to the cut's width) without a warning
DEFAULT_METHOD_TOLERANCE = 0.01


@dataclass(frozen=True)
class ValidationRuns:
    """The validation runs of a study, evaluated and reduced, and what to do with them.

    Attributes
    ----------
    points : the validation points of every round.
    outcome : what the check found (:class:`~fuzzymbs.fuzzy.validation.SearchOutcome`;
        the validation outputs themselves only when kept).
    failed, reasons : (V,) per run.
    tolerance : the study's ``method_tolerance``; widen : ``widen_with_validation``.
    evaluated, reused : runs evaluated now and taken from the store.
    """

    points: ValidationPoints
    outcome: SearchOutcome
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
    rounds : validation runs per round.
    error : largest miss over outputs, levels and elements, on the cut-width scale
        (NaN: no validation run could be checked); a lower bound of the true miss.
    tolerance : the study's ``method_tolerance``.
    per_output : output -> its largest miss.
    worst : where the largest miss is (output, level, parameter values, element), or None.
    widened : the bounds were widened with the validation outputs.
    excursion : output -> (V,) each point's largest excursion over the elements.
    bound : :data:`~fuzzymbs.fuzzy.band_scale.LOWER_BOUND`: ``error`` comes from sampled
        validation runs, so the true miss is at least ``error`` and can be larger.
    """

    runs: int
    failed: int
    rounds: list[int]
    error: float
    tolerance: float
    per_output: dict[str, float]
    worst: dict[str, Any] | None
    widened: bool
    excursion: dict[str, np.ndarray] = field(repr=False)
    bound: str = LOWER_BOUND

    def to_attrs(self) -> dict[str, Any]:
        """Dataset attributes (NetCDF-safe numbers and strings)."""
        return {
            "method_error": float(self.error),
            "method_error_bound": self.bound,
            "method_tolerance": float(self.tolerance),
            "validation_runs": int(self.runs),
        }

    def to_provenance(self) -> dict[str, Any]:
        """The provenance entry ``method_check``."""
        return {
            "runs": self.runs,
            "failed": self.failed,
            "rounds": list(self.rounds),
            "error": self.error,
            "bound": self.bound,
            "tolerance": self.tolerance,
            "per_output": self.per_output,
            "worst": self.worst,
            "widened": self.widened,
        }


def check_method(
    names: Sequence[str],
    levels: np.ndarray,
    cuts: Mapping[str, tuple[np.ndarray, np.ndarray]],
    validation: ValidationRuns,
) -> MethodCheck:
    """The method check's verdict from the reduced validation runs; warns above the
    tolerance and widens the cuts in place when the study asks for it.

    Parameters
    ----------
    names : the plan's parameter names (columns of the points' samples).
    levels : (L,) the plan's levels.
    cuts : output -> ``(lower, upper)``, each (L, *shape); widened in place when
        ``validation.widen`` (every level whose box holds a point: the point's level and
        all below, so the cuts stay nested).
    validation : the study's validation runs.
    """
    outcome = validation.outcome
    points = validation.points
    error = outcome.error
    tolerance = validation.tolerance
    worst = None
    if outcome.worst is not None:
        point = outcome.worst["point"]
        worst = {
            "output": outcome.worst["output"],
            "level": float(levels[outcome.worst["level"]]),
            "parameters": dict(zip(names, points.samples[point].tolist(), strict=True)),
            "element": outcome.worst["element"],
            "excursion": float(error),
        }
    if validation.widen:
        for name, (lower, upper) in cuts.items():
            low = outcome.low[name]
            high = outcome.high[name]
            np.minimum(lower, np.where(np.isfinite(low), low, lower), out=lower)
            np.maximum(upper, np.where(np.isfinite(high), high, upper), out=upper)
    result = MethodCheck(
        runs=len(points),
        failed=int(np.count_nonzero(validation.failed)),
        rounds=list(outcome.rounds),
        error=float(error),
        tolerance=float(tolerance),
        per_output=dict(outcome.per_output),
        worst=worst,
        widened=bool(validation.widen),
        excursion=dict(outcome.point_excursion),
        bound=outcome.bound,
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
