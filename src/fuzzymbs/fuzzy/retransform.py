"""Retransformation: alpha-cuts of a fuzzy output from model outputs at the plan's samples.

Bounds are nested by construction (Hanss): ``lower^(m)`` is the minimum over
the level-m outputs and, going down, ``lower^(j) = min(lower^(j+1), min over
the level-j outputs)``; likewise the upper bounds with max. Outputs may have
any trailing shape (time, nodes, ...); everything is element-wise.

Sparse plans (Klimke & Wohlmuth 2005) bound each level by a search of the
sparse-grid interpolant over the level's cut box: the candidates are the
samples inside the box (their model outputs) and a tensor grid of the box
(``k = max(3, floor(search_points^(1/n)))`` points per parameter, corners
included) evaluated by the interpolant; the bounds are their min/max, nested
as above. For scalar outputs the three best candidates for the minimum (and
for the maximum) then start a bounded L-BFGS-B search of the interpolant in
the box (SciPy); outputs with a trailing shape keep the grid search, whose
extrema between grid points are found up to the grid spacing.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidFuzzyNumberError,
    ModelOutputError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy.accumulate import (
    MONOTONIC_RTOL,
    AccumulatedBounds,
    NonMonotonicWarning,
    OutputAccumulator,
    StreamLayout,
)
from fuzzymbs.fuzzy.bookkeeping import PlanBookkeeping
from fuzzymbs.fuzzy.grids import cartesian, unique_rows
from fuzzymbs.fuzzy.influence import Influence, influence_from_sums, influence_refusal
from fuzzymbs.fuzzy.labels import DatasetExport, DatasetParts
from fuzzymbs.fuzzy.numbers import check_level
from fuzzymbs.fuzzy.sparse_grid import SparseGrid

__all__ = [
    "MONOTONIC_RTOL",
    "FuzzyResult",
    "NonMonotonicWarning",
    "cut_index",
    "from_accumulated",
    "retransform",
]


def cut_index(levels: NDArray[np.float64], mu: float) -> int:
    """Index of the computed level whose cut answers a query at ``mu``.

    That is the lowest level >= ``mu`` (the next level up; nothing is
    interpolated); a level within 1e-12 of ``mu`` counts as ``mu`` itself.

    Raises
    ------
    InvalidFuzzyNumberError
        If ``mu`` is not a number in [0, 1].
    """
    value = check_level(mu)
    index = int(np.searchsorted(levels, value, side="left"))
    if index > 0 and abs(levels[index - 1] - value) <= 1e-12:
        index -= 1
    return min(index, len(levels) - 1)


class FuzzyResult(DatasetExport):
    """Fuzzy output: nested alpha-cut bounds at the plan's membership levels.

    Parameters
    ----------
    levels : array_like, shape (L,)
        Membership levels mu_0 = 0 ... mu_m = 1.
    lower, upper : array_like, shape (L, ...)
        Cut bounds, nested (lower non-decreasing and upper non-increasing in
        the level); NaN where ``complete`` is False.
    complete : array_like of bool, shape (L,), optional
        False for levels whose bounds depend on failed samples (default all True).
    nominal : array_like, shape (...), optional
        Output at the all-modal parameter point.
    method : str, optional
        The scheme that produced the result.

    Attributes
    ----------
    levels, lower, upper, complete, nominal, method
        As above; arrays are read-only.

    Notes
    -----
    :meth:`to_xarray` gives ``{name}_lower`` and ``{name}_upper`` over
    ("level", *dims), ``{name}_complete`` over ("level",) and, if known,
    ``{name}_nominal`` over dims; the coordinate "level" holds mu and the
    attribute ``{name}_method`` the scheme.
    """

    def __init__(
        self,
        levels: ArrayLike,
        lower: ArrayLike,
        upper: ArrayLike,
        complete: ArrayLike | None = None,
        nominal: ArrayLike | None = None,
        method: str | None = None,
        *,
        _plan: PlanBookkeeping | None = None,
        _sums: tuple[NDArray[np.float64], NDArray[np.bool_]] | None = None,
    ) -> None:
        self.levels = np.asarray(levels, dtype=float)
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        count = len(self.levels)
        if self.lower.shape != self.upper.shape or self.lower.ndim < 1 or len(self.lower) != count:
            raise InvalidFuzzyNumberError(
                f"lower and upper must both have shape (L={count}, ...), got "
                f"{self.lower.shape} and {self.upper.shape}"
            )
        self.complete = (
            np.ones(count, dtype=bool) if complete is None else np.asarray(complete, dtype=bool)
        )
        if self.complete.shape != (count,):
            raise InvalidFuzzyNumberError(
                f"complete must have shape ({count},), got {self.complete.shape}"
            )
        self.nominal = None if nominal is None else np.asarray(nominal, dtype=float)
        self.method = method
        self._plan = _plan
        self._sums = _sums  # (corner pair sums, levels with a failed corner): influence
        for array in (self.levels, self.lower, self.upper, self.complete, self.nominal):
            if array is not None:
                array.setflags(write=False)

    def __repr__(self) -> str:
        return (
            f"FuzzyResult(method={self.method!r}, levels={len(self.levels)}, "
            f"shape={self.shape}, complete={bool(self.complete.all())})"
        )

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of one bound (the output's own shape, without the level axis)."""
        return self.lower.shape[1:]

    def alpha_cut(self, mu: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Bounds ``(lower, upper)`` of the cut at level ``mu``.

        Between two computed levels the cut of the next level up is returned
        (the result is known only at the plan's levels; nothing is interpolated).

        Raises
        ------
        InvalidFuzzyNumberError
            If ``mu`` is outside [0, 1].
        """
        index = cut_index(self.levels, mu)
        return self.lower[index].copy(), self.upper[index].copy()

    def influence(self, weights: str | ArrayLike = "membership") -> Influence:
        """Gain factors and influence measures (reduced, extended, grid and adaptive plans;
        the adaptive method's come from its certified surrogate at the cut-box corners).

        Parameters
        ----------
        weights : {"membership", "uniform"} or array_like (L,)
            Level weights w_j: mu_j, 1, or explicit non-negative values.

        Raises
        ------
        UnsupportedOperationError
            For general and grid plans, or a result not built from a plan.
        """
        if self._plan is None:
            raise UnsupportedOperationError(
                "influence needs the plan and the sample outputs; this FuzzyResult was built "
                "from bounds only (use plan.retransform(outputs).influence())"
            )
        if not self._plan.scheme.supports_influence or self._sums is None:
            raise UnsupportedOperationError(influence_refusal(self._plan))
        pair_sum, bad_level = self._sums
        return influence_from_sums(self._plan, pair_sum, bad_level, self.shape, weights)

    def dataset_parts(self, name: str, dims: list[str]) -> DatasetParts:
        """Bounds, completeness and nominal output as Dataset variables (see the Notes)."""
        variables: dict[str, Any] = {
            f"{name}_lower": (("level", *dims), self.lower),
            f"{name}_upper": (("level", *dims), self.upper),
            f"{name}_complete": (("level",), self.complete),
        }
        if self.nominal is not None:
            variables[f"{name}_nominal"] = (tuple(dims), self.nominal)
        attrs = {} if self.method is None else {f"{name}_method": self.method}
        return DatasetParts(variables, {"level": self.levels}, attrs)


def _checked_outputs(
    plan: PlanBookkeeping, outputs: ArrayLike, failed: NDArray[np.bool_], name: str
) -> NDArray:
    values = np.asarray(outputs)
    if values.ndim == 0 or values.shape[0] != len(plan):
        raise ModelOutputError(
            f"output {name!r} must have leading axis N={len(plan)} (one row per sample), "
            f"got shape {values.shape}"
        )
    if not (np.issubdtype(values.dtype, np.number) or values.dtype == np.bool_):
        raise ModelOutputError(f"output {name!r} must be numeric, got dtype {values.dtype}")
    values = values.astype(float, copy=False)
    finite = np.isfinite(values).reshape(len(plan), -1).all(axis=1)
    bad = ~finite & ~failed
    if bad.any():
        raise ModelOutputError(
            f"output {name!r} has NaN or inf at {int(bad.sum())} sample(s) not marked failed "
            f"(first: sample {int(np.flatnonzero(bad)[0])}); pass failed=<bool mask> to "
            "report them as failed runs"
        )
    return values


def retransform(
    plan: PlanBookkeeping,
    outputs: ArrayLike,
    failed: ArrayLike | None = None,
    *,
    name: str = "output",
    check_monotonic: bool = True,
) -> FuzzyResult:
    """Nested alpha-cut bounds of one output (see :meth:`Plan.retransform`).

    Raises
    ------
    ModelOutputError
        Wrong leading axis, non-numeric, or non-finite values at samples not
        marked failed.
    InvalidPlanError
        A malformed ``failed`` mask.
    IncompleteResultError
        A sparse plan with failed samples (its interpolant needs every sample).
    """
    mask = plan.check_failed(failed)
    values = _checked_outputs(plan, outputs, mask, name)
    count_levels = len(plan.levels)
    shape = values.shape[1:]
    if plan.scheme.interpolates:
        if mask.any():
            raise IncompleteResultError(
                f"output {name!r}: {int(mask.sum())} of {len(plan)} samples of the sparse plan "
                f"failed (first: sample {int(np.flatnonzero(mask)[0])}); the sparse-grid "
                "interpolant needs every sample, so no level can be bounded. Fix the failing "
                "runs or use another method (e.g. 'general') to keep the complete levels"
            )
        own_lower, own_upper = _sparse_own_bounds(plan, values)
        lower = np.minimum.accumulate(own_lower[::-1], axis=0)[::-1]
        upper = np.maximum.accumulate(own_upper[::-1], axis=0)[::-1]
        return FuzzyResult(
            plan.levels,
            lower.reshape((count_levels, *shape)),
            upper.reshape((count_levels, *shape)),
            nominal=values[plan.nominal_index],
            method=plan.method,
            _plan=plan,
        )
    accumulator = OutputAccumulator(StreamLayout(plan), values.shape[1:])
    accumulator.update(0, values, mask)
    return from_accumulated(
        plan, accumulator.finish(mask, name=name, check_monotonic=check_monotonic)
    )


def from_accumulated(plan: PlanBookkeeping, bounds: AccumulatedBounds) -> FuzzyResult:
    """A :class:`FuzzyResult` from an accumulator's bounds (:mod:`fuzzymbs.fuzzy.accumulate`)."""
    sums = None if bounds.pair_sum is None else (bounds.pair_sum, bounds.bad_level)
    return FuzzyResult(
        plan.levels,
        bounds.lower,
        bounds.upper,
        complete=bounds.complete,
        nominal=bounds.nominal,
        method=plan.method,
        _plan=plan,
        _sums=sums,
    )


#: float64 elements per block of interpolation weights or interpolated values
_SEARCH_BLOCK_ELEMENTS = 2_000_000


def points_per_parameter(search_points: int, count_parameters: int) -> int:
    """Search-grid points per parameter: ``max(3, floor(search_points^(1/n)))``."""
    k = max(1, round(search_points ** (1.0 / count_parameters)))
    while k > 1 and k**count_parameters > search_points:
        k -= 1
    while (k + 1) ** count_parameters <= search_points:
        k += 1
    return max(3, k)


def _sparse_own_bounds(plan: PlanBookkeeping, values: NDArray) -> tuple[NDArray, NDArray]:
    """Per-level min/max (L, E) of a sparse plan's candidates (see the module docstring)."""
    count_levels, count_parameters = plan.cut_lower.shape
    plan.scheme.check_bounds(count_parameters)  # a search it cannot run is refused
    flat = values.reshape(len(plan), -1)
    node_values = flat[plan.node_index]
    grid = plan.sparse_grid
    per_parameter = points_per_parameter(plan.search_points, count_parameters)
    block = max(1, _SEARCH_BLOCK_ELEMENTS // max(len(grid), flat.shape[1]))
    own_lower = np.empty((count_levels, flat.shape[1]))
    own_upper = np.empty((count_levels, flat.shape[1]))
    for j in range(count_levels):
        low, high = plan.cut_lower[j], plan.cut_upper[j]
        inside = np.all((plan.samples >= low) & (plan.samples <= high), axis=1)
        # the modal point is a sample inside every cut box, so `inside` is never empty
        own_lower[j] = flat[inside].min(axis=0)
        own_upper[j] = flat[inside].max(axis=0)
        # np.linspace returns the bounds exactly; a zero-width cut gives one value
        axes = [
            np.unique(np.linspace(low[i], high[i], per_parameter)) for i in range(count_parameters)
        ]
        points = cartesian(axes)
        # grid points that are samples keep their model output (already counted)
        _, inverse = unique_rows(np.concatenate((plan.samples, points), axis=0))
        points = points[inverse[len(plan) :] >= len(plan)]
        unit = plan.to_unit_cube(points)
        pieces = []
        for start in range(0, len(unit), block):
            interpolated = grid.weights(unit[start : start + block]) @ node_values
            np.minimum(own_lower[j], interpolated.min(axis=0), out=own_lower[j])
            np.maximum(own_upper[j], interpolated.max(axis=0), out=own_upper[j])
            if flat.shape[1] == 1:
                pieces.append(interpolated[:, 0])
        if flat.shape[1] == 1 and np.any(high > low):
            # scalar output: polish the best candidates with a local search of the interpolant
            candidates = np.concatenate((plan.to_unit_cube(plan.samples[inside]), unit), axis=0)
            candidate_values = np.concatenate((flat[inside, 0], *pieces))
            box = list(zip(plan.to_unit_cube(low), plan.to_unit_cube(high), strict=True))
            for sign, bound in ((1.0, own_lower), (-1.0, own_upper)):
                starts = candidates[np.argsort(sign * candidate_values)[:_REFINE_STARTS]]
                best = _local_search(grid, node_values[:, 0], starts, box, sign)
                bound[j, 0] = min(sign * bound[j, 0], best) * sign
    return own_lower, own_upper


#: candidates that start a local search per bound (scalar outputs of sparse plans)
_REFINE_STARTS = 3


def _local_search(
    grid: SparseGrid,
    node_values: NDArray[np.float64],
    starts: NDArray[np.float64],
    box: list[tuple[float, float]],
    sign: float,
) -> float:
    """Smallest ``sign * interpolant`` found by L-BFGS-B from each start within the box.

    Value and central-difference gradient (step 1e-6 in the unit cube, one-sided
    at its faces) come from one weights call of 2n + 1 points.
    """
    from scipy.optimize import minimize

    count = len(box)
    step = 1e-6 * np.eye(count)

    def value_and_gradient(unit: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        plus = np.clip(unit + step, 0.0, 1.0)
        minus = np.clip(unit - step, 0.0, 1.0)
        values = sign * (grid.weights(np.vstack((unit[None, :], plus, minus))) @ node_values)
        spacing = np.diagonal(plus - minus)
        return float(values[0]), (values[1 : count + 1] - values[count + 1 :]) / spacing

    best = np.inf
    for start in starts:
        found = minimize(value_and_gradient, start, jac=True, method="L-BFGS-B", bounds=box)
        if np.isfinite(found.fun):
            best = min(best, float(found.fun))
    return best
