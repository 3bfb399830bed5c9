"""The scale a fuzzy result is read on: the cut width.

Every error of a fuzzy study (the method's miss, the time integration's
deviation) is divided by the local cut width, floored at a tenth of the widest
cut of that output at that level,

    e_j(i) = d_j(i) / max(w_j(i), 0.1 max_i w_j(i)),

so that elements where every run agrees (a signal's start) do not turn
round-off into large ratios, while a band a few tenths of a per cent of the
peak wide is still judged on its own width.

A method error on this scale is one of two kinds (:data:`LOWER_BOUND`,
:data:`CERTIFIED`): the fixed methods' check runs the model at sampled points and can
only show that the miss is at least what those points reach; the adaptive method's
estimate is certified by its own refinement rounds.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CERTIFIED",
    "LOWER_BOUND",
    "WIDTH_FLOOR",
    "band_miss",
    "level_widest",
    "width_relative",
]

#: floor of the local cut width, as a fraction of the widest cut of that output and level
WIDTH_FLOOR = 0.1
#: kind of a method error found by sampled validation runs: the true miss is at least it
LOWER_BOUND = "lower"
#: kind of the adaptive method's error estimate: certified by its refinement rounds
CERTIFIED = "certified"


def level_widest(width: NDArray[np.float64]) -> NDArray[np.float64]:
    """(L, 1) the widest finite cut of each level of ``width`` (L, size); NaN where a
    level has no finite width."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN levels
        return np.nanmax(np.where(np.isfinite(width), width, np.nan), axis=1, keepdims=True)


def width_relative(
    deviation: NDArray[np.float64], lower: NDArray[np.float64], upper: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``deviation / max(w, 0.1 max_e w)`` per level and element, all (L, size); NaN on
    levels whose cuts have no width anywhere and where the deviation is NaN."""
    width = upper - lower
    widest = level_widest(width)
    scale = np.maximum(width, WIDTH_FLOOR * widest)
    crisp = ~(widest > 0.0)
    ratio = np.full(deviation.shape, np.nan)
    usable = np.isfinite(deviation) & ~np.broadcast_to(crisp, deviation.shape)
    ratio[usable] = deviation[usable] / scale[usable]
    return ratio


def band_miss(
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    true_lower: NDArray[np.float64],
    true_upper: NDArray[np.float64],
) -> float:
    """The largest part of the true cuts outside the computed ones, on the cut-width scale.

    Parameters
    ----------
    lower, upper : (L, ...) the computed cuts of one output (level first).
    true_lower, true_upper : (L, ...) its true cuts.

    Returns
    -------
    float
        ``max_j,i (max(l - l*, 0) + max(u* - u, 0)) / max(w*, 0.1 max_i w*)`` with
        ``[l*, u*]`` the true cut and ``w*`` its width; 0 when every true cut lies
        inside the computed one; NaN when no level has a true width.
    """
    lo = np.asarray(lower, dtype=float).reshape(len(lower), -1)
    hi = np.asarray(upper, dtype=float).reshape(len(upper), -1)
    tlo = np.asarray(true_lower, dtype=float).reshape(lo.shape)
    thi = np.asarray(true_upper, dtype=float).reshape(hi.shape)
    outside = np.maximum(lo - tlo, 0.0) + np.maximum(thi - hi, 0.0)
    outside = np.minimum(outside, thi - tlo)  # never more than the whole true cut
    ratio = width_relative(outside, tlo, thi)
    if not np.isfinite(ratio).any():
        return float("nan")
    return float(np.nanmax(ratio))
