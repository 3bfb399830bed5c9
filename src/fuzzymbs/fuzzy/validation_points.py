"""The validation points of a plan: where a method's own check runs the model.

:func:`validation_points` makes the first round of the check of
:mod:`fuzzymbs.fuzzy.validation` (edge probes from the runs that bound each cut and
scrambled Halton points in the mu = 0 box); :func:`interpolant_optima` the points
where a sparse plan's interpolant reaches its bounds; :func:`box_level` the level
against which each point is checked; :func:`cut_scale` and :func:`excursions` the
cut-width scale on which a point's excursion beyond a cut is read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.band_scale import WIDTH_FLOOR, level_widest
from fuzzymbs.fuzzy.halton import halton
from fuzzymbs.fuzzy.transform import Plan

__all__ = [
    "FIRST_STEP",
    "OPTIMUM_CANDIDATES",
    "SEED",
    "ValidationPoints",
    "box_level",
    "cut_scale",
    "excursions",
    "interpolant_optima",
    "validation_points",
    "zigzag",
]

#: first step of the local search, as a fraction of the half-width of the level's box
FIRST_STEP = 0.25
#: seed of the scrambled Halton sequence (reproducible points, resumable stores)
SEED = 20261125


@dataclass(frozen=True)
class ValidationPoints:
    """Validation points of a plan.

    Attributes
    ----------
    samples : (V, n) parameter values, columns in ``plan.names`` order.
    level : (V,) index of the highest level whose cut box contains each point.
    kind : (V,) "edge", "halton" or "search".
    step : (V,) the local search's step that made the point (a fraction of the
        half-width of its level's box), :data:`FIRST_STEP` for the first round's points.
    """

    samples: NDArray[np.float64]
    level: NDArray[np.int64]
    kind: NDArray[np.str_]
    step: NDArray[np.float64] | None = None

    def __len__(self) -> int:
        return len(self.samples)


def box_level(plan: Plan, samples: NDArray[np.float64]) -> NDArray[np.int64]:
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
        unit = halton(rest, n, seed=seed)
        points.extend(bottom[:, 0] + unit * (bottom[:, 1] - bottom[:, 0]))
        kinds.extend(["halton"] * rest)
    samples = np.asarray(points, dtype=float).reshape(count, n)
    return ValidationPoints(samples, box_level(plan, samples), np.asarray(kinds))


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


def cut_scale(lower: NDArray[np.float64], upper: NDArray[np.float64]) -> NDArray[np.float64]:
    """The cut-width scale of one output, (L, size): ``max(w, 0.1 max_e w)`` per level
    (:func:`fuzzymbs.fuzzy.band_scale.width_relative`); a level whose cuts have no width
    anywhere (a crisp core) is read on a tenth of the output's widest cut of any level,
    NaN where even that is zero or the bounds are unknown."""
    lo = np.asarray(lower, dtype=float).reshape(len(lower), -1)
    hi = np.asarray(upper, dtype=float).reshape(len(upper), -1)
    width = hi - lo
    widest = level_widest(width)
    overall = np.nanmax(widest) if np.isfinite(widest).any() else np.nan
    widest = np.where(widest > 0.0, widest, overall)
    scale = np.maximum(width, WIDTH_FLOOR * widest)
    scale[~(scale > 0.0)] = np.nan
    return scale


def excursions(
    lower: NDArray[np.float64],
    upper: NDArray[np.float64],
    values: NDArray[np.float64],
    level: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Excursion of each point beyond its level's cut, on the cut-width scale.

    Parameters
    ----------
    lower, upper : (L, *shape) the method's cuts of one output.
    values : (V, *shape) the output at the validation points (NaN rows: failed).
    level : (V,) the level each point is checked against.

    Returns
    -------
    ndarray (V, *shape)
        ``max(l - y, y - u, 0) / max(w, 0.1 max_e w)`` per element, with ``w`` the
        local width of the point's level's cut and ``max_e w`` the widest cut of that
        output at that level (:func:`cut_scale`; the normalisation of every error of a
        study, :mod:`fuzzymbs.fuzzy.band_scale`); NaN where the point failed or its
        level's bounds are unknown.
    """
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    values = np.asarray(values, dtype=float)
    level = np.asarray(level, dtype=np.int64)
    scale = cut_scale(lower, upper)[level].reshape(values.shape)
    low = lower[level]
    high = upper[level]
    with np.errstate(invalid="ignore"):
        outside = np.maximum(np.maximum(low - values, values - high), 0.0)
        relative = outside / scale
    unknown = ~(np.isfinite(values) & np.isfinite(low) & np.isfinite(high) & np.isfinite(scale))
    relative[unknown] = np.nan
    return relative


#: interpolant evaluations per level box when a sparse plan's optima are looked for
OPTIMUM_CANDIDATES = 512


def interpolant_optima(
    plan: Plan,
    outputs: Mapping[str, NDArray[np.float64]] | None,
    failed: NDArray[np.bool_] | None,
    limit: int,
) -> NDArray[np.float64]:
    """Up to ``limit`` points where a sparse plan's interpolant reaches its cut bounds
    (approximately: the best of :data:`OPTIMUM_CANDIDATES` Halton points of each level's
    box, per output element), the most frequent first, the levels taking turns. Its
    bounds lie there, often away from every run: the true model at these points checks
    them. Empty for other plans (their bounds are runs) or failed runs."""
    n = len(plan.names)
    if not plan.scheme.interpolates or not outputs or limit <= 0:
        return np.empty((0, n))
    if failed is not None and np.any(failed):
        return np.empty((0, n))
    boxes = np.stack([plan.parameters[name].cuts(plan.levels) for name in plan.names], axis=1)
    unit = halton(OPTIMUM_CANDIDATES, n, seed=SEED + 1)
    levels = [j for j in range(len(plan.levels)) if np.any(boxes[j, :, 1] > boxes[j, :, 0])]
    table = np.concatenate(
        [boxes[j, :, 0] + unit * (boxes[j, :, 1] - boxes[j, :, 0]) for j in levels]
    )
    level = box_level(plan, table)
    ranked: dict[tuple[int, int], list[int]] = {}
    for values in outputs.values():
        flat = plan.interpolate(values, table).reshape(len(table), -1)
        for j in levels:
            rows = np.flatnonzero(level >= j)
            for side, arg in enumerate((np.argmin, np.argmax)):
                best = rows[arg(flat[rows], axis=0)]
                index, tally = np.unique(best, return_counts=True)
                ranked.setdefault((j, side), []).extend(index[np.argsort(-tally, kind="stable")])
    chosen: list[int] = []
    rank = 0
    while len(chosen) < limit and any(rank < len(v) for v in ranked.values()):
        for j in zigzag(list(levels)):
            for side in (0, 1):
                listed = ranked.get((j, side), [])
                if rank < len(listed) and listed[rank] not in chosen and len(chosen) < limit:
                    chosen.append(int(listed[rank]))
        rank += 1
    return table[chosen]


def zigzag(values: list[int]) -> list[int]:
    """0, 5, 1, 4, 2, 3 from 0..5: the outermost and innermost levels first."""
    rest = list(values)
    order = []
    while rest:
        order.append(rest.pop(0))
        if rest:
            order.append(rest.pop())
    return order
