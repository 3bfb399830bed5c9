"""The adaptive method's noise rule: when the model's own noise, not the surrogate, is what
remains.

A model whose outputs carry an error of their own that does not shrink with the
spacing of the runs (a fixed-step integrator too coarse for the dynamics, an
iterative solver with a loose tolerance) cannot be certified below that error:
the certified error of the adaptive method (:mod:`fuzzymbs.fuzzy.adaptive`)
stalls, and rises again as the surrogate grows rougher through more and more
noisy runs. :class:`NoiseRule` measures the noise once the error has stalled
(twin runs, each ``_TWIN_OFFSET`` beside a certification run, outside the
surrogate) and says when the rounds should stop for it (docs/fuzzy.md, "When
the model's noise stops it"). It is a part of
:class:`~fuzzymbs.fuzzy.adaptive.AdaptiveTransformation` (its base class), kept in
a file of its own because it is an idea of its own.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["TWIN", "NoiseRule"]

#: rounds in a row without a new smallest error (above the tolerance) before twin runs probe
#: the model's noise; 3, because the hard test cases' errors rise for up to two rounds while
#: the refinement resolves an extremum (bump3: 0.026, 0.085, 0.076, then 0.0048)
_STALL_ROUNDS = 3
#: twin runs per probing round, each beside one of the last round's certification runs
_TWINS = 4
#: a twin's offset from its run (unit cube, every moving coordinate): far below the node
#: spacing and the certification's ``_NEAR``, so a smooth model differs there by its slope
#: times 1e-4 of the support and the spread is the model's own noise
_TWIN_OFFSET = 2e-4
#: the rounds stop as limited by noise when, stalled, the smallest error they reached is at
#: most this multiple of the noise (the certification's ``|f - s|`` at a new run is itself
#: a spread between noisy runs, measured at 1 to 7 times the twins' spread)
_NOISE_FACTOR = 2.0
#: a batch label: a twin run (off the grid, outside the surrogate)
TWIN = "twin"


class NoiseRule:
    """Stall detection, twin runs and the noise stop of the adaptive method's rounds (the
    attributes below are the engine's)."""

    errors: list[float]
    tolerance: float
    noise: float
    runs: int
    _last_batch: NDArray[np.intp]
    _last_predicted: NDArray[np.float64]
    _off_grid: NDArray[np.intp]
    _units: NDArray[np.float64]
    _values: NDArray[np.float64] | None
    _low: NDArray[np.float64]
    _high: NDArray[np.float64]
    _bounds: tuple | None
    _scale: Callable[[], NDArray[np.float64]]
    _levels_holding: Callable[[NDArray[np.float64]], NDArray[np.intp]]

    def _stalled(self) -> bool:
        """The error, above the tolerance, has not reached a new smallest value for
        ``_STALL_ROUNDS`` rounds in a row: time to measure the model's noise."""
        errors = self.errors
        if len(errors) <= _STALL_ROUNDS or errors[-1] <= self.tolerance:
            return False
        return min(errors[-_STALL_ROUNDS:]) >= min(errors[:-_STALL_ROUNDS])

    def _noise_limited(self) -> bool:
        """The noise, measured once the error stalled, is above the tolerance, and the
        smallest error the rounds reached is at most ``_NOISE_FACTOR`` times the noise:
        refinement never got below the noise (under noise the error rises again as the
        surrogate, through ever more noisy runs, grows rougher), so it cannot reach the
        tolerance. The stall need not last: a noisy error reaches a new smallest value
        now and then by chance, and the noise does not go away with it."""
        if not self.noise > self.tolerance:
            return False
        return min(self.errors) <= _NOISE_FACTOR * self.noise

    def _twin_points(self, room: int) -> NDArray[np.float64]:
        """Up to ``_TWINS`` points (unit cube) each ``_TWIN_OFFSET`` beside one of the last
        round's certification runs (the most doubtful first), inside the cube."""
        batch = self._last_batch
        bases = batch[np.isin(batch, self._off_grid)][: min(_TWINS, max(room, 0))]
        moving = self._high > self._low
        units = self._units[bases]
        step = np.where(units + _TWIN_OFFSET <= 1.0, _TWIN_OFFSET, -_TWIN_OFFSET)
        return np.where(moving, units + step, units)

    def _spread(self, rows: NDArray[np.intp]) -> float:
        """The largest ``|f - s|`` (cut-width scale of the highest level holding the point)
        at the batch's twins ``rows``: ``s`` was built through the neighbour a twin sits
        beside, so this is the model's spread over ``_TWIN_OFFSET``."""
        assert self._values is not None
        index = self.runs - len(self._last_predicted) + rows
        error = np.abs(self._values[index] - self._last_predicted[rows])
        scale = self._scale() if self._bounds is not None else None
        if scale is None:
            return 0.0
        holding = self._levels_holding(self._units[index])
        relative = error / scale[holding]
        return float(np.max(np.where(np.isfinite(relative), relative, 0.0), initial=0.0))
