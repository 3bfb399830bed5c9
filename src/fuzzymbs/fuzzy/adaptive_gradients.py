"""What the adaptive method does differently with the model's gradients.

Where the model returns the gradients of its outputs with respect to the fuzzy
parameters, every run carries ``n + 1`` data per output element. Besides the
surrogate's Hermite correction (:mod:`fuzzymbs.fuzzy.hermite_correction`), the
rounds of :class:`~fuzzymbs.fuzzy.adaptive.AdaptiveTransformation` then

- check each extremum's first-order (Karush-Kuhn-Tucker) conditions at its
  confirming run (:mod:`fuzzymbs.fuzzy.first_order`) when they confirm the
  extrema: a gap enters the reported error, and an extremum whose gap exceeds
  the tolerance gets a step on the model;
- let the sparse grid's refinement rest while the surrogate predicts the new
  runs well (:meth:`GradientRounds._settled`): its surpluses know the values
  only, and the surrogate through values and gradients is often accurate long
  before they have decayed;
- let the sparse grid interpolate its nodes' derivatives too, along one direction
  it has refined to ``_HERMITE_LEVEL``, when that predicts the runs off the grid
  better than the values alone (:meth:`GradientRounds._choose_hermite`).

:class:`GradientRounds` is a part of the engine (its base class), kept in a file of
its own because it is an idea of its own. Without gradients none of it acts: the
rounds are bit for bit those of a model without them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.chebyshev_grid import ChebyshevSparseGrid, evaluate_series
from fuzzymbs.fuzzy.first_order import first_order_check, first_order_steps, open_gap

__all__ = ["GradientRounds"]

#: with the model's gradients the sparse grid is refined only while the last round's runs
#: show the surrogate off by more than this many tolerances (how far their error could carry
#: a value beyond the bounds), after a confirmation that found it off, or while a
#: first-order gap stays open (measured, before the first round's rest: 1, 3 and 10
#: tolerances took bump3 107, 67, 67 runs, valley4 93, 93, 69, sdof 2 % 177, 123, 123,
#: all within the tolerance)
_SETTLED = 10.0
#: the sparse grid may take its nodes' derivatives along a direction once it holds this
#: level there (9 nodes), where a level's Hermite interpolant (degree 2 m - 1) resolves what
#: the next level's values would. Measured (benchmarks/gradient_adaptive.py, runs with
#: gradients; Hermite from level 0 / 2 / 3 / 4 / never): ringing3 210 / 210 / 164 / 175 / 217,
#: bump3 144 / 105 / 67 / 67 / 67, sdof 2 % 137 / 186 / 90 / 90 / 90, 2dof 2 % - / 191 / 128 /
#: 128 / 128: through 3 or 5 nodes the interpolant of degree 5 or 9 swings between them
_HERMITE_LEVEL = 3


class GradientRounds:
    """The first-order check and the refinement's rest of the adaptive method's rounds with
    the model's gradients (the attributes below are the engine's)."""

    names: tuple[str, ...]
    grid: ChebyshevSparseGrid
    errors: list[float]
    tolerance: float
    rounds: int
    max_runs: int
    runs: int
    _slopes: NDArray[np.float64] | None
    _sloped: NDArray[np.bool_]
    _off_grid: NDArray[np.intp]
    _twins: NDArray[np.intp]
    _bounds: tuple[NDArray, ...] | None
    _open_gap: bool
    _last_batch: NDArray[np.intp]
    _last_predicted: NDArray[np.float64]
    _units: NDArray[np.float64]
    _values: NDArray[np.float64] | None
    _low: NDArray[np.float64]
    _high: NDArray[np.float64]
    _box_low: NDArray[np.float64]
    _box_high: NDArray[np.float64]
    _scale: Callable[[], NDArray[np.float64]]
    _relevant_miss: Callable[..., NDArray[np.float64]]
    _widened: Callable[[], tuple[NDArray[np.float64], NDArray[np.float64]]]

    def _settled(self) -> bool:
        """With the model's gradients, whether the sparse grid's refinement rests this round
        (the round's points are certification and exploration runs only): every run carries
        ``n + 1`` data, and the surrogate through their values and gradients is often
        accurate long before the grid's surpluses, which know the values only, have decayed.
        It rests in the first round with a surrogate (the runs certify it before anything
        is refined) and while the last round's runs show no error that could carry a value
        more than ``_SETTLED`` tolerances beyond the bounds; it works again after a
        confirmation round that found the surrogate off by more than the tolerance, and
        while a first-order gap stays open that no step can close (measured: without the
        former, the 0.5 % resonance ridge stopped at 978 runs missing 3.2 % of the cut
        width for 0.9 % reported). Never without gradients."""
        if self._slopes is None or not self._sloped.any():
            return False
        if self.rounds == 1:
            return True
        opened, self._open_gap = self._open_gap, False
        batch = self._last_batch
        seen = self._relevant_miss(self._units[batch], self._values[batch], self._last_predicted)
        return not opened and float(seen.max(initial=0.0)) <= _SETTLED * self.tolerance

    def _choose_hermite(self) -> None:
        """With the model's gradients at every node, the sparse grid's Hermite direction:
        of the values-only grid and the grids Hermite along a direction refined to
        ``_HERMITE_LEVEL``, the one that predicts the runs off the grid best (they are held
        out of the grid's series; the mean over them of the largest error over the
        elements, on the support's cut-width scale). Values only while no direction
        qualifies, or without gradients."""
        grid = self.grid
        held_out = np.setdiff1d(self._off_grid, self._twins)
        levels = np.max(np.array(grid.indices), axis=0)
        directions = [int(d) for d in np.flatnonzero(levels >= _HERMITE_LEVEL)]
        if not grid.has_slopes() or not directions or not len(held_out) or self._bounds is None:
            grid.use_hermite(None)
            return
        assert self._values is not None
        scale = self._scale()[0]
        weight = np.where(np.isfinite(scale), 1.0 / scale, 0.0)
        best, smallest = None, np.inf
        for direction in (None, *directions):  # a tie keeps the values only
            grid.use_hermite(direction)
            predicted = evaluate_series(*grid.series(), self._units[held_out])
            miss = (np.abs(self._values[held_out] - predicted) * weight).max(axis=1)
            if float(miss.mean()) < smallest:
                best, smallest = direction, float(miss.mean())
        grid.use_hermite(best)

    def _first_order(
        self, surrogate: tuple, bounds: tuple[NDArray, ...], near: float
    ) -> tuple[NDArray[np.float64], float]:
        """With the model's gradients, each extremum's first-order conditions checked at its
        confirming run (:mod:`fuzzymbs.fuzzy.first_order`): the steps (P, n) of those whose
        gap (beyond the reported bounds) exceeds the tolerance, the largest gap first, and
        the largest gap of the extrema whose step no run has taken yet
        (:func:`~fuzzymbs.fuzzy.first_order.open_gap`), which the reported error includes.
        None and 0 without gradients."""
        dimension = len(self.names)
        if self._slopes is None or not self._sloped.any():
            return np.empty((0, dimension)), 0.0
        moving = self._high > self._low
        check = first_order_check(
            surrogate, *bounds[2:], (self._box_low, self._box_high), self._scale(),
            (self._units, self._values, self._slopes, self._sloped), moving, near,
            self._widened(),
        )  # fmt: skip
        limit = min(4 * dimension, self.max_runs - self.runs)
        steps = first_order_steps(
            check, self._units, moving, tolerance=self.tolerance, near=near, limit=limit
        )
        return steps, open_gap(check, self._units, moving, near)
