"""Online retransformation: alpha-cut bounds, gain-factor sums and monotonicity checks
accumulated chunk by chunk, in memory bounded by the output's shape, not the run count.

:class:`OutputAccumulator` is fed the outputs of consecutive chunks of a plan's
samples (any chunk sizes, in sample order) and keeps, per output element:

* per level, the smallest and largest output of the level's own points and
  the sample that gave it (the runs that bound a cut: the method check's
  probes start there, :mod:`fuzzymbs.fuzzy.validation`);
* the output at the all-modal point;
* reduced and extended plans: the signed sums of the corner outputs that make
  the gain factors (:mod:`fuzzymbs.fuzzy.influence`), summed sample by sample
  in sample order, so the result does not depend on how the samples were cut
  into chunks; and, per level and group of equal non-monotonic coordinates,
  the range of the level's own points and of the points of the levels above
  (the monotonicity guard: an inner point outside the corner range).

:func:`fuzzymbs.fuzzy.retransform.retransform` feeds all samples at once; a
study feeds each chunk as it arrives (``fuzzymbs.study``) and drops it.
Sparse plans are not accumulated: their interpolant needs every sample.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.bookkeeping import PlanBookkeeping
from fuzzymbs.fuzzy.grids import unique_rows

__all__ = [
    "MONOTONIC_RTOL",
    "AccumulatedBounds",
    "NonMonotonicWarning",
    "OutputAccumulator",
    "StreamLayout",
]

#: relative tolerance of the monotonicity guard (round-off must not warn)
MONOTONIC_RTOL = 1e-9


class NonMonotonicWarning(UserWarning):
    """A reduced/extended retransformation found points inside a level's cut box
    whose outputs fall outside the range of that level's corner runs: the model is
    not monotonic where the method assumes it is, so the bounds are too narrow."""


class AccumulatedBounds(NamedTuple):
    """What an accumulator gives: the nested bounds and what the influence needs.

    ``lower``/``upper`` (L, *shape) with NaN at levels touched by failed samples,
    ``complete`` (L,), ``nominal`` (*shape) (NaN if the all-modal run failed),
    ``pair_sum`` (n, L, E) signed corner sums or None (general, grid), ``bad_level``
    (L,) levels with a failed corner.
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    complete: NDArray[np.bool_]
    nominal: NDArray[np.float64]
    pair_sum: NDArray[np.float64] | None
    bad_level: NDArray[np.bool_]


class StreamLayout:
    """A plan's bookkeeping arranged for accumulation (built once, shared by outputs).

    Raises
    ------
    InvalidPlanError
        For a sparse plan (its interpolant needs every sample at once).
    """

    def __init__(self, plan: PlanBookkeeping) -> None:
        if not plan.scheme.supports_streaming:
            raise InvalidPlanError(
                f"{plan.method} plans are retransformed from all samples at once"
            )
        self.plan = plan
        self.count = len(plan)
        self.usage = np.asarray(plan.level_usage, dtype=bool)  # (L, N)
        self.levels = len(plan.levels)
        self.nominal_index = int(plan.nominal_index)
        # corner sums (gain factors): plans with corner bookkeeping (reduced, extended,
        # grid); the monotonicity guard: methods whose bounds assume monotonic outputs
        # (reduced, extended; a grid's bounds use every grid point)
        self.corners = plan.scheme.has_corners
        self.guard = plan.scheme.guards_monotonicity
        if self.guard:
            self._guard_layout(plan)
        if self.corners:
            self._corner_layout(plan)

    def _guard_layout(self, plan: PlanBookkeeping) -> None:
        """Groups of equal non-monotonic coordinates and each level's inner points."""
        columns = [plan.names.index(parameter) for parameter in plan.nonmonotonic]
        if columns:
            _, group = unique_rows(np.asarray(plan.samples)[:, columns])
        else:
            group = np.zeros(self.count, dtype=np.intp)
        self.group = np.asarray(group, dtype=np.intp)
        self.groups = int(self.group.max()) + 1 if self.count else 1
        # the guard's candidates of level j: points of the levels above (and the nominal
        # point) that are not level-j points and share non-monotonic coordinates with one
        self.candidate = np.zeros_like(self.usage)
        inner = self.usage[-1].copy()
        for j in range(self.levels - 2, -1, -1):
            present = np.zeros(self.groups, dtype=bool)
            present[self.group[self.usage[j]]] = True
            self.candidate[j] = inner & ~self.usage[j] & present[self.group]
            inner |= self.usage[j]

    def _corner_layout(self, plan: PlanBookkeeping) -> None:
        """Corner occurrences in sample order: (sample, level, slot), for the gain sums."""
        corners = np.asarray(plan.corner_index)  # (L, 2^n)
        order = np.argsort(corners.ravel(), kind="stable")
        self.occurrence_sample = corners.ravel()[order]
        self.occurrence_level, self.occurrence_slot = np.divmod(order, corners.shape[1])
        n = len(plan.names)
        bits = (np.arange(corners.shape[1])[None, :] >> np.arange(n - 1, -1, -1)[:, None]) & 1
        # sign[i, s] = +1 if corner s has parameter i at its upper bound, else -1
        self.sign = (2.0 * bits - 1.0) / 2.0 ** (n - 1)


class OutputAccumulator:
    """Alpha-cut bounds of one output, accumulated from consecutive chunks.

    Parameters
    ----------
    layout : StreamLayout
        The plan's bookkeeping.
    shape : tuple of int
        The output's trailing shape (``()`` for a scalar).
    """

    def __init__(self, layout: StreamLayout, shape: tuple[int, ...]) -> None:
        self.layout = layout
        self.shape = tuple(shape)
        size = int(np.prod(self.shape, dtype=np.int64))
        levels = layout.levels
        self.own_min = np.full((levels, size), np.inf)
        self.own_max = np.full((levels, size), -np.inf)
        self.arg_min = np.full((levels, size), -1, dtype=np.int64)
        self.arg_max = np.full((levels, size), -1, dtype=np.int64)
        self.nominal = np.full(size, np.nan)
        self.scale = 0.0  # largest finite magnitude (the guard's round-off floor)
        self.fed = 0  # samples fed so far (chunks arrive in sample order)
        self.pair_sum: NDArray[np.float64] | None = None
        self.bad_level = np.zeros(levels, dtype=bool)  # levels with a failed corner
        if layout.corners:
            self.pair_sum = np.zeros((layout.sign.shape[0], levels, size))
        if layout.guard:
            # guard ranges per (level, group): the level's own points and its candidates
            if layout.groups > 1:
                self.group_min = np.full((levels, layout.groups, size), np.inf)
                self.group_max = np.full((levels, layout.groups, size), -np.inf)
            self.inner_min = np.full((levels, layout.groups, size), np.inf)
            self.inner_max = np.full((levels, layout.groups, size), -np.inf)

    def update(self, start: int, values: NDArray[np.float64], failed: NDArray[np.bool_]) -> None:
        """Feed samples ``start .. start + B - 1``: outputs (B, *shape), failed (B,).

        Failed samples are left out (their levels become incomplete at the end).

        Raises
        ------
        InvalidPlanError
            Samples out of order or of the wrong shape.
        """
        values = np.asarray(values, dtype=float)
        size = len(values)
        if start != self.fed:
            raise InvalidPlanError(
                f"chunks must arrive in sample order: expected sample {self.fed}, got {start}"
            )
        if values.shape[1:] != self.shape or len(failed) != size:
            raise InvalidPlanError(
                f"chunk of shape {values.shape} (failed {np.shape(failed)}) for outputs of "
                f"trailing shape {self.shape}"
            )
        self.fed += size
        layout = self.layout
        flat = values.reshape(size, -1)
        ok = ~np.asarray(failed, dtype=bool)
        if ok.any():
            good = flat[ok]
            finite = np.isfinite(good)
            if finite.any():
                self.scale = max(self.scale, float(np.max(np.abs(good[finite]))))
        nominal = layout.nominal_index - start
        if 0 <= nominal < size and ok[nominal]:
            self.nominal = flat[nominal].copy()
        columns = np.arange(flat.shape[1])
        for j in range(layout.levels):
            rows = np.flatnonzero(layout.usage[j, start : start + size] & ok)
            if rows.size == 0:
                continue
            block = flat[rows]
            low = block.argmin(axis=0)
            value, index = block[low, columns], rows[low] + start
            # strictly smaller, or equal from an earlier sample: the first sample wins
            better = (value < self.own_min[j]) | (
                (value == self.own_min[j]) & (index < self.arg_min[j])
            )
            self.own_min[j] = np.where(better, value, self.own_min[j])
            self.arg_min[j] = np.where(better, index, self.arg_min[j])
            high = block.argmax(axis=0)
            value, index = block[high, columns], rows[high] + start
            better = (value > self.own_max[j]) | (
                (value == self.own_max[j]) & (index < self.arg_max[j])
            )
            self.own_max[j] = np.where(better, value, self.own_max[j])
            self.arg_max[j] = np.where(better, index, self.arg_max[j])
        if layout.guard:
            self._update_guard(start, flat, ok)
        if layout.corners:
            self._update_sums(start, flat, ok)

    def _update_guard(self, start: int, flat: NDArray[np.float64], ok: NDArray) -> None:
        layout = self.layout
        stop = start + len(flat)
        for j in range(layout.levels - 1):
            # guard ranges: own points per group (groups > 1; else own_min/own_max) and
            # candidates (inner points) per group
            own = np.flatnonzero(layout.usage[j, start:stop] & ok)
            if layout.groups > 1 and own.size:
                np.minimum.at(self.group_min[j], layout.group[own + start], flat[own])
                np.maximum.at(self.group_max[j], layout.group[own + start], flat[own])
            inner = np.flatnonzero(layout.candidate[j, start:stop] & ok)
            if inner.size:
                np.minimum.at(self.inner_min[j], layout.group[inner + start], flat[inner])
                np.maximum.at(self.inner_max[j], layout.group[inner + start], flat[inner])

    def _update_sums(self, start: int, flat: NDArray[np.float64], ok: NDArray) -> None:
        """Gain sums, one corner occurrence after the other in sample order."""
        layout = self.layout
        stop = start + len(flat)
        first, last = np.searchsorted(layout.occurrence_sample, [start, stop])
        assert self.pair_sum is not None
        for k in range(first, last):
            sample = int(layout.occurrence_sample[k]) - start
            level = int(layout.occurrence_level[k])
            if not ok[sample]:
                self.bad_level[level] = True
                continue
            slot = int(layout.occurrence_slot[k])
            self.pair_sum[:, level, :] += layout.sign[:, slot, None] * flat[sample][None, :]

    def finish(
        self, failed: NDArray[np.bool_], name: str = "output", check_monotonic: bool = True
    ) -> AccumulatedBounds:
        """The nested bounds once every sample was fed (``failed``: (N,) of the whole plan).

        Warns (:class:`NonMonotonicWarning`) when a reduced/extended plan's inner
        points fall outside their level's corner range.
        """
        layout = self.layout
        if self.fed != layout.count:
            raise InvalidPlanError(f"{self.fed} of {layout.count} samples fed; feed them all")
        plan = layout.plan
        lower = np.minimum.accumulate(self.own_min[::-1], axis=0)[::-1]
        upper = np.maximum.accumulate(self.own_max[::-1], axis=0)[::-1]
        touched = plan.levels_touched(np.asarray(failed, dtype=bool))
        if check_monotonic and layout.guard:
            self._guard(touched, name)
        lower = lower.copy()
        upper = upper.copy()
        lower[touched] = np.nan
        upper[touched] = np.nan
        shape = (layout.levels, *self.shape)
        return AccumulatedBounds(
            lower.reshape(shape),
            upper.reshape(shape),
            ~touched,
            self.nominal.reshape(self.shape),
            self.pair_sum,
            self.bad_level.copy(),
        )

    def nested_extremes(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
        """``(lower, upper, lower_sample, upper_sample)``, each (L, size): the nested bounds
        of the samples fed so far and the sample that gives each (-1: none).

        Level j's cut holds the points of levels j and above, so its bound is the
        extreme over them (as in :meth:`finish`); on a tie the inner level's sample
        is kept.
        """
        found = []
        for own, arg, better in (
            (self.own_min, self.arg_min, np.less),
            (self.own_max, self.arg_max, np.greater),
        ):
            values = own.copy()
            samples = arg.copy()
            for j in range(self.layout.levels - 2, -1, -1):
                keep = ~better(own[j], values[j + 1])
                values[j] = np.where(keep, values[j + 1], own[j])
                samples[j] = np.where(keep, samples[j + 1], arg[j])
            found.append((values, samples))
        (lower, lower_sample), (upper, upper_sample) = found
        return lower, upper, lower_sample, upper_sample

    def bound_tally(self, level: int) -> NDArray[np.int64]:
        """(N,) how many output elements each sample bounds (smallest or largest) at ``level``."""
        tally = np.zeros(self.layout.count, dtype=np.int64)
        for arg in (self.arg_min[level], self.arg_max[level]):
            valid = arg[arg >= 0]
            tally += np.bincount(valid, minlength=self.layout.count)
        return tally

    def _guard(self, touched: NDArray[np.bool_], name: str) -> None:
        """Inner points of level j outside the range of level j's own points (per group)."""
        layout = self.layout
        worst_level, worst_excess, worst_count = -1, 0.0, 0
        for j in range(layout.levels - 2, -1, -1):
            if touched[j]:
                break  # touched levels are j and everything below it
            if layout.groups > 1:
                low, high = self.group_min[j], self.group_max[j]
            else:
                low, high = self.own_min[j][None, :], self.own_max[j][None, :]
            below, above = self.inner_min[j], self.inner_max[j]
            present = np.isfinite(below) & np.isfinite(low)
            if not present.any():
                continue
            outside = np.zeros(below.shape, dtype=bool)
            relative = 0.0
            with np.errstate(invalid="ignore", over="ignore"):
                # the extreme inner points are the ones that leave the range first
                for z in (below, above):
                    size = np.maximum(np.maximum(np.abs(low), np.abs(high)), np.abs(z))
                    excess = np.maximum(low - z, z - high)
                    out = present & (excess > MONOTONIC_RTOL * size + 1e-12 * self.scale)
                    if out.any():
                        outside |= out
                        relative = max(
                            relative, float(np.max(excess[out] / np.maximum(size[out], 1e-300)))
                        )
            count = int(np.count_nonzero(outside.any(axis=0)))
            if count:
                if worst_level < 0 or relative > worst_excess:
                    worst_level, worst_excess, worst_count = j, relative, count
        if worst_level >= 0:
            plan = layout.plan
            treated = (
                "the parameters not named nonmonotonic" if plan.nonmonotonic else "every parameter"
            )
            warnings.warn(
                f"output {name!r} is not monotonic in {treated}: at level "
                f"mu={plan.levels[worst_level]:g} points inside the cut box gave outputs outside "
                f"the range of that level's corner runs for {worst_count} output element(s) "
                f"(up to {worst_excess:.3g} relative), so the {plan.method} bounds are too "
                "narrow. Use method='extended' with nonmonotonic=[...], or method='general'.",
                NonMonotonicWarning,
                stacklevel=4,
            )
