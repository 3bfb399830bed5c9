"""Validation runs: a transformation method's own check of the output ranges it found.

Every scheme sees the model only at its points: the reduced method at the
corners of each cut box (exact for models monotonic in every parameter), the
extended method also inside along the non-monotonic parameters' axes, the
general and grid methods on their grids, the sparse-grid method through an
interpolant. An interior extremum between those points is missed without a
trace: the retransformation's :class:`~fuzzymbs.fuzzy.retransform.NonMonotonicWarning`
only compares the points the method evaluated.

The validation runs are extra points inside the cut boxes that no run of the
method covers, evaluated with the same model. Each point ``x`` is checked
against the cut of the highest level whose box contains it (the exact alpha-cut
of that level contains ``f(x)``; the boxes are nested, so that level's cut is
the tightest). Its excursion beyond the method's cut ``[l_j, u_j]``, relative
to the cut's width,

    e(x) = max(l_j - f(x), f(x) - u_j, 0) / (u_j - l_j),

per output element like the retransformation, is a lower bound of the
method's true miss at that level; the study's ``method_error`` is the largest
over points, levels and elements.

Points (:func:`validation_points`), ``count`` in all:

* half of them (rounded up), when the method's outputs are given: **edge
  probes** from the runs that bound each cut. For every level below the core
  and every output element, the level's run giving the smallest and the one
  giving the largest value are tallied; from the most frequent such runs on,
  one parameter at a time is moved half-way towards its modal value (from a
  corner of the box: the quarter point of the edge towards the centre). The
  levels take turns (a probe of level 0, one of the next level, ...). An
  extremum inside the box next to a bounding run, such as a valley that the
  corners straddle while other parameters sit at their bounds, lies on such
  an edge;
* the rest: a scrambled Halton sequence (:class:`scipy.stats.qmc.Halton`, fixed
  seed) in the mu = 0 box, space-filling in every dimension, for extrema away
  from the bounding runs. Points fall into the inner boxes in proportion to
  their volume and are checked there.

The split is justified by tests (tests/fuzzy/test_validation.py) on models with
known exact ranges. What the estimate cannot see: misses smaller than the
points' spacing, extrema in corners of the box the sequence does not reach
with few points, and (being a lower bound) it never overstates a miss.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.transform import Plan

__all__ = [
    "SMALL_STUDY",
    "ValidationPoints",
    "default_validation_count",
    "excursions",
    "validation_points",
]

#: studies with at least this many runs get a fifth of their runs as validation runs
SMALL_STUDY = 30
#: seed of the scrambled Halton sequence (reproducible points, resumable stores)
SEED = 20261125


def default_validation_count(runs: int, parameters: int) -> int:
    """Default number of validation runs: a fifth of the method's runs (at least
    ``n + 1``) for studies of :data:`SMALL_STUDY` runs or more, ``n + 1`` below."""
    if runs >= SMALL_STUDY:
        return max(parameters + 1, runs // 5)
    return parameters + 1


@dataclass(frozen=True)
class ValidationPoints:
    """Validation points of a plan.

    Attributes
    ----------
    samples : (V, n) parameter values, columns in ``plan.names`` order.
    level : (V,) index of the highest level whose cut box contains each point.
    kind : (V,) "edge" or "halton".
    """

    samples: NDArray[np.float64]
    level: NDArray[np.int64]
    kind: NDArray[np.str_]

    def __len__(self) -> int:
        return len(self.samples)


def _box_level(plan: Plan, samples: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the highest level whose cut box contains each sample (0 at least)."""
    cuts = np.stack([plan.parameters[n].cuts(plan.levels) for n in plan.names], axis=1)
    # cuts (L, n, 2); a tolerance of 1e-12 of the mu = 0 width for points on a bound
    width = cuts[0, :, 1] - cuts[0, :, 0]
    slack = 1e-12 * np.where(width > 0, width, 1.0)
    inside = (samples[None, :, :] >= cuts[:, None, :, 0] - slack) & (
        samples[None, :, :] <= cuts[:, None, :, 1] + slack
    )
    inside = inside.all(axis=2)  # (L, V)
    level = np.zeros(len(samples), dtype=np.int64)
    for j in range(len(plan.levels)):
        level[inside[j]] = j
    return level


def validation_points(
    plan: Plan,
    count: int,
    outputs: Mapping[str, NDArray[np.float64]] | None = None,
    failed: NDArray[np.bool_] | None = None,
    seed: int = SEED,
    *,
    tally: Callable[[int], NDArray[np.int64]] | None = None,
) -> ValidationPoints:
    """``count`` validation points of ``plan`` (module docstring).

    Parameters
    ----------
    plan : the study's plan.
    count : number of points (0: none).
    outputs : output -> (N, ...) the method's outputs in plan order; without
        them every point is a Halton point.
    failed : (N,) bool, the method's failed runs (not used as probe origins).
    seed : seed of the scrambled Halton sequence.
    tally : instead of ``outputs``: ``tally(level)`` -> (N,) how many output elements
        each sample bounds at that level (a study's online retransformation counts them,
        :meth:`fuzzymbs.fuzzy.accumulate.OutputAccumulator.bound_tally`).

    Raises
    ------
    InvalidPlanError
        ``count`` negative or not an integer.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise InvalidPlanError(f"validation runs must be a whole number >= 0, got {count!r}")
    n = len(plan.names)
    if count == 0:
        return ValidationPoints(np.empty((0, n)), np.empty(0, np.int64), np.empty(0, "<U6"))
    bottom = np.array([plan.parameters[name].cuts([0.0])[0] for name in plan.names])  # (n, 2)
    modal = np.array([plan.parameters[name].modal for name in plan.names])
    points: list[NDArray[np.float64]] = []
    kinds: list[str] = []
    if outputs or tally is not None:
        for point in _edge_probes(plan, modal, outputs or {}, failed, -(-count // 2), tally):
            points.append(point)
            kinds.append("edge")
    rest = count - len(points)
    if rest > 0:
        from scipy.stats import qmc

        unit = qmc.Halton(d=n, scramble=True, seed=seed).random(rest)
        points.extend(bottom[:, 0] + unit * (bottom[:, 1] - bottom[:, 0]))
        kinds.extend(["halton"] * rest)
    samples = np.asarray(points, dtype=float).reshape(count, n)
    return ValidationPoints(samples, _box_level(plan, samples), np.asarray(kinds))


def _edge_probes(
    plan: Plan,
    modal: NDArray[np.float64],
    outputs: Mapping[str, NDArray[np.float64]],
    failed: NDArray[np.bool_] | None,
    limit: int,
    tally: Callable[[int], NDArray[np.int64]] | None = None,
) -> list[NDArray[np.float64]]:
    """Up to ``limit`` edge probes, taken from the levels below the core in turn (one
    probe of level 0, one of the next level, ...), so that every cut is probed."""
    per_level = [
        _level_probes(plan, j, modal, outputs, failed, limit, tally)
        for j in range(len(plan.levels) - 1)
    ]
    probes: list[NDArray[np.float64]] = []
    for rank in range(limit):
        for level_probes in per_level:
            if rank < len(level_probes) and len(probes) < limit:
                probes.append(level_probes[rank])
    return probes


def _level_probes(
    plan: Plan,
    level: int,
    modal: NDArray[np.float64],
    outputs: Mapping[str, NDArray[np.float64]],
    failed: NDArray[np.bool_] | None,
    limit: int,
    bound_tally: Callable[[int], NDArray[np.int64]] | None = None,
) -> list[NDArray[np.float64]]:
    """Up to ``limit`` probes of one level: from the runs that bound its cut most often
    (per output element, smallest and largest), each parameter moved half-way to its
    modal value."""
    usable = np.asarray(plan.level_usage[level], dtype=bool).copy()
    if failed is not None:
        usable &= ~np.asarray(failed, dtype=bool)
    rows = np.flatnonzero(usable)
    if len(rows) == 0:
        return []
    tally = np.zeros(len(plan), dtype=np.int64)
    if bound_tally is not None:
        tally[rows] = np.asarray(bound_tally(level))[rows]
    for values in outputs.values():
        flat = np.asarray(values, dtype=float)[rows].reshape(len(rows), -1)
        finite = np.isfinite(flat).all(axis=0)
        if not finite.any():
            continue
        flat = flat[:, finite]
        np.add.at(tally, rows[np.argmin(flat, axis=0)], 1)
        np.add.at(tally, rows[np.argmax(flat, axis=0)], 1)
    origins = [int(i) for i in np.argsort(-tally, kind="stable") if tally[i] > 0]
    probes: list[NDArray[np.float64]] = []
    for origin in origins:
        start = plan.samples[origin]
        for i in range(len(modal)):
            if len(probes) == limit:
                return probes
            if start[i] == modal[i]:
                continue  # already at the centre along this parameter
            probe = start.copy()
            probe[i] = 0.5 * (start[i] + modal[i])
            probes.append(probe)
    return probes


def excursions(
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    values: NDArray[np.float64],
    level: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Excursion of each point beyond its level's cut, relative to the cut's width.

    Parameters
    ----------
    lower, upper : (L, *shape) the method's cuts of one output.
    values : (V, *shape) the output at the validation points (NaN rows: failed).
    level : (V,) the level each point is checked against.

    Returns
    -------
    ndarray (V, *shape)
        ``max(l - y, y - u, 0) / w`` per element, with the width ``w`` floored
        at 1e-9 of the output's widest cut (so that elements where every run
        agrees, such as a signal's start, do not turn round-off into large
        ratios); NaN where the point failed or its level's bounds are unknown.
    """
    low = lower[level]
    high = upper[level]
    outside = np.maximum(np.maximum(low - values, values - high), 0.0)
    width = high - low
    widest = np.nanmax(upper - lower) if np.isfinite(upper - lower).any() else 0.0
    floor = max(1e-9 * float(widest), np.finfo(float).tiny)
    with np.errstate(invalid="ignore"):
        relative = outside / np.maximum(width, floor)
    unknown = ~(np.isfinite(values) & np.isfinite(low) & np.isfinite(high))
    relative[unknown] = np.nan
    return relative
