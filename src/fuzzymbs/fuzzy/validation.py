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
the tightest), and it counts for every level below too. Per level ``j`` and
output element ``i`` the part of the validation runs' range outside the
method's cut ``[l, u]``, on the cut-width scale of
:mod:`fuzzymbs.fuzzy.band_scale`,

    e_j(i) = (max(l - min f, 0) + max(max f - u, 0)) / max(k_j(i), 0.1 max_i k_j(i)),

with ``k`` the width of the known cut (the method's cut widened by the
validation runs), is the method's miss that the check found; the study's
``method_error`` is its largest value over outputs, levels and elements
(:meth:`MethodSearch.outcome`). It is the formula of the true miss against
dense-grid truth (:func:`~fuzzymbs.fuzzy.band_scale.band_miss`) with the
validation runs in place of the truth, so it is at most the true miss where
the method's cut lies inside the true one: a lower bound of the miss
(:attr:`SearchOutcome.bound` is :data:`~fuzzymbs.fuzzy.band_scale.LOWER_BOUND`), since
a sample can show that a cut is missed but never that it is not. :func:`excursions` reads each
run's own excursion on the method's cut width (a diagnostic).

The points, ``count`` in all, in :data:`ROUNDS` rounds (:class:`MethodSearch`;
each round is one batch of model runs, its outputs reduced as they arrive):

* round 1, a quarter of them (:func:`validation_points`): **edge probes** from
  the runs that bound each cut (for every level below the core and every output
  element, the level's run giving the smallest and the one giving the largest
  value are tallied; from the most frequent such runs on, one parameter at a
  time is moved half-way towards its modal value; the levels take turns), and
  a scrambled Halton sequence (:func:`fuzzymbs.fuzzy.halton.halton`, fixed seed) in
  the mu = 0 box, space-filling, for extrema away from the bounding runs;
* rounds 2 to 4, the rest shared equally: a **local search** from the points
  that give each level's bounds now (the method's runs, or validation runs
  that beat them; for a sparse plan, whose bounds are no run's, the best
  validation runs, and its first round also runs the true model at the
  interpolant's optima). From each start a compass step of :data:`FIRST_STEP`
  of the level box's half-width along each parameter, both ways, clipped to
  the box, then one step to the vertex of the parabolas through those steps; a
  start that stays the best after both is searched again with half the step;
  a validation run that improved a bound starts with the step that found it.
  Starts inside their level's box (an interior extremum: for a monotonic model
  every bound lies on a corner) come first; the levels take turns from both
  ends (outermost, innermost, ...).

The default count, a fifth of the runs and at least :data:`PER_PARAMETER` per
parameter, and the rounds were chosen on the hard cases of
:mod:`fuzzymbs.models.closed_form.hard_cases` and two models of the tests, where the
reported error is at least 0.63 of the true miss for every fixed method (docs/fuzzy.md,
benchmarks/method_check_honesty.py). What the check cannot see: a narrow
extremum far from every start and between the Halton points, or a second
extremum beside the one the search climbs.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.band_scale import LOWER_BOUND
from fuzzymbs.fuzzy.halton import halton
from fuzzymbs.fuzzy.transform import Plan
from fuzzymbs.fuzzy.validation_points import (
    FIRST_STEP,
    SEED,
    ValidationPoints,
    box_level,
    cut_scale,
    excursions,
    interpolant_optima,
    validation_points,
    zigzag,
)

__all__ = [
    "PER_PARAMETER",
    "ROUNDS",
    "MethodSearch",
    "ValidationPoints",
    "check_plan",
    "default_validation_count",
    "excursions",
    "validation_points",
]

#: the floor of the default count: this many validation runs per fuzzy parameter
PER_PARAMETER = 12
#: rounds of the check: the first (edge probes and Halton points), then local search
ROUNDS = 4
#: share of the validation runs in the first round
FIRST_ROUND_SHARE = 0.25


def default_validation_count(runs: int, parameters: int) -> int:
    """Default number of validation runs: a fifth of the method's runs, at least
    :data:`PER_PARAMETER` per fuzzy parameter (``12 n``; measured on the hard cases of
    :mod:`fuzzymbs.models.closed_form.hard_cases`, docs/fuzzy.md)."""
    return max(PER_PARAMETER * parameters, runs // 5)


class _Extremes:
    """One output's validation values reduced per level: the nested smallest and largest
    value of the points in each level's box and the point that gives it, and each
    point's largest excursion."""

    def __init__(self, lower: NDArray[np.float64], upper: NDArray[np.float64]) -> None:
        self.shape = np.shape(lower)[1:]
        self.lower = np.asarray(lower, dtype=float).reshape(len(lower), -1)
        self.upper = np.asarray(upper, dtype=float).reshape(len(upper), -1)
        self.scale = cut_scale(self.lower, self.upper)
        levels, size = self.lower.shape
        self.low = np.full((levels, size), np.inf)
        self.high = np.full((levels, size), -np.inf)
        self.low_point = np.full((levels, size), -1, dtype=np.int64)
        self.high_point = np.full((levels, size), -1, dtype=np.int64)
        self.point_excursion: list[NDArray[np.float64]] = []
        self.point_element: list[NDArray[np.int64]] = []

    def add(self, first: int, values: NDArray[np.float64], level: NDArray[np.int64]) -> None:
        """Points ``first, first + 1, ...`` with their values (B, *shape) (NaN: failed)."""
        flat = np.asarray(values, dtype=float).reshape(len(values), -1)
        usable = np.isfinite(flat).all(axis=1)
        relative = excursions(self.lower, self.upper, flat, level).reshape(len(flat), -1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: failed points
            worst = np.nanmax(relative, axis=1) if flat.shape[1] else np.full(len(flat), np.nan)
        element = np.zeros(len(flat), dtype=np.int64)
        found = np.isfinite(worst)
        if found.any():
            element[found] = np.nanargmax(relative[found], axis=1)
        self.point_excursion.append(worst)
        self.point_element.append(element)
        for j in range(len(self.low)):
            rows = np.flatnonzero(usable & (level >= j))  # level j's box holds these
            if len(rows) == 0:
                continue
            block = flat[rows]
            arg = np.argmin(block, axis=0)
            value = block[arg, np.arange(block.shape[1])]
            better = value < self.low[j]
            self.low[j, better] = value[better]
            self.low_point[j, better] = first + rows[arg[better]]
            arg = np.argmax(block, axis=0)
            value = block[arg, np.arange(block.shape[1])]
            better = value > self.high[j]
            self.high[j, better] = value[better]
            self.high_point[j, better] = first + rows[arg[better]]

    def miss(self) -> NDArray[np.float64]:
        """(L, size) the part of the validation range outside the method's cut, on the
        cut-width scale of the known range (the method's cut widened by the validation
        runs, the best inner estimate of the true cut; NaN where no point or no bound)."""
        with np.errstate(invalid="ignore"):
            outside = np.maximum(self.lower - self.low, 0.0) + np.maximum(
                self.high - self.upper, 0.0
            )
            known_lower = np.where(
                np.isfinite(self.low), np.minimum(self.lower, self.low), self.lower
            )
            known_upper = np.where(
                np.isfinite(self.high), np.maximum(self.upper, self.high), self.upper
            )
            relative = outside / cut_scale(known_lower, known_upper)
        relative[~np.isfinite(relative)] = np.nan
        return relative


@dataclass(frozen=True)
class SearchOutcome:
    """What the method check found (:meth:`MethodSearch.outcome`).

    Attributes
    ----------
    points : every validation point of every round, in evaluation order.
    error : largest miss over outputs, levels and elements (NaN: nothing checked): a
        lower bound of the method's true miss, which can be larger.
    per_output : output -> its largest miss.
    worst : output, level index, point index and element (flat index) of the largest
        miss, or None.
    point_excursion : output -> (V,) each point's largest excursion over the elements.
    low, high : output -> (L, *shape) the nested smallest and largest validation value
        of each level's box (inf / -inf where no point).
    outputs : output -> (V, *shape) the validation outputs, when kept.
    rounds : points per round.
    bound : :data:`~fuzzymbs.fuzzy.band_scale.LOWER_BOUND`: ``error`` comes from sampled
        validation runs, so the true miss is at least ``error``.
    """

    points: ValidationPoints
    error: float
    per_output: dict[str, float]
    worst: dict[str, Any] | None
    point_excursion: dict[str, NDArray[np.float64]]
    low: dict[str, NDArray[np.float64]]
    high: dict[str, NDArray[np.float64]]
    outputs: dict[str, NDArray[np.float64]] | None
    rounds: list[int]
    bound: str = LOWER_BOUND


class MethodSearch:
    """The method check of one plan in rounds: which points to run next, and the
    reduction of their outputs (module docstring).

    Parameters
    ----------
    plan : the plan.
    cuts : output -> ``(lower, upper)``, each (L, *shape): the method's cuts.
    count : validation runs in all (the rounds share them).
    bounds_from : output -> ``(lower_sample, upper_sample)``, each (L, size): the plan
        sample that gives each nested cut bound (-1: none), as
        :meth:`fuzzymbs.fuzzy.accumulate.OutputAccumulator.nested_extremes` gives them;
        the starting points of the local search besides the validation points.
    outputs : output -> (N, ...) the method's outputs (instead of ``bounds_from``
        and ``tally``; sparse plans, checks by hand).
    tally : ``tally(level)`` -> (N,) how many output elements each sample bounds at
        that level (the first round's edge probes).
    failed : (N,) the method's failed runs.
    keep_outputs : keep the validation outputs whole (else only their reduction).
    seed : seed of the scrambled Halton sequence.
    rounds : number of rounds (default :data:`ROUNDS`).

    Notes
    -----
    Deterministic: the points of a round depend only on the plan, the cuts and the
    outputs of the earlier rounds, so a rerun (or a resumed store) proposes the same.
    """

    def __init__(
        self,
        plan: Plan,
        cuts: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]],
        count: int,
        *,
        bounds_from: Mapping[str, tuple[NDArray[np.int64], NDArray[np.int64]]] | None = None,
        outputs: Mapping[str, NDArray[np.float64]] | None = None,
        tally: Callable[[int], NDArray[np.int64]] | None = None,
        failed: NDArray[np.bool_] | None = None,
        keep_outputs: bool = True,
        seed: int = SEED,
        rounds: int | None = None,
    ) -> None:
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
            raise InvalidPlanError(f"validation runs must be a whole number >= 0, got {count!r}")
        self.plan = plan
        self.count = int(count)
        self.rounds = max(1, int(ROUNDS if rounds is None else rounds))
        self._outputs = outputs
        self._tally = tally
        self._failed = failed
        self._seed = seed
        self._keep = keep_outputs
        self._extremes = {name: _Extremes(lo, hi) for name, (lo, hi) in cuts.items()}
        self._cuts = {
            name: (
                np.asarray(lo, dtype=float).reshape(len(lo), -1),
                np.asarray(hi, dtype=float).reshape(len(hi), -1),
            )
            for name, (lo, hi) in cuts.items()
        }
        if bounds_from is None and outputs is not None:
            bounds_from = _bounding_samples(plan, outputs, failed)
        self._bounds_from = dict(bounds_from or {})
        self._boxes = np.stack([plan.parameters[n].cuts(plan.levels) for n in plan.names], axis=1)
        self._rounds: list[ValidationPoints] = []
        self._kept: dict[str, list[NDArray[np.float64]]] = {}
        self._fed = 0  # points of the finished rounds plus those of the current one fed
        self._expanded: dict[tuple[bytes, int, int], dict[str, Any]] = {}
        #: search points -> (output, element) whose value the parabola fit needs
        self._tracked: dict[int, tuple[str, int]] = {}
        self._values: dict[int, float] = {}

    # ------------------------------------------------------------------ rounds
    def _budget(self) -> int:
        """Points of the next round."""
        done = sum(len(r) for r in self._rounds)
        left = self.count - done
        if left <= 0:
            return 0
        if not self._rounds:
            first = max(1, round(FIRST_ROUND_SHARE * self.count)) if self.rounds > 1 else left
            return min(first, left)
        remaining_rounds = self.rounds - len(self._rounds)
        if remaining_rounds <= 0:
            return 0
        return -(-left // remaining_rounds)

    def next_round(self) -> ValidationPoints | None:
        """The points of the next round (None: the check is done). The outputs of the
        previous round must have been fed (:meth:`add`) first."""
        evaluated = sum(len(r) for r in self._rounds)
        if self._fed != evaluated:
            raise RuntimeError(f"{self._fed} of {evaluated} validation outputs fed")
        budget = self._budget()
        if budget == 0:
            return None
        if not self._rounds:
            optima = interpolant_optima(self.plan, self._outputs, self._failed, budget // 2)
            points = validation_points(
                self.plan,
                budget - len(optima),
                self._outputs,
                self._failed,
                self._seed,
                tally=self._tally,
            )
            samples = np.concatenate([optima, points.samples]) if len(optima) else points.samples
            kinds = np.concatenate([np.full(len(optima), "optimum"), points.kind])
            points = ValidationPoints(
                samples, box_level(self.plan, samples), kinds, np.full(len(samples), FIRST_STEP)
            )
        else:
            points = self._search(budget)
            if points is None:
                return None
        self._rounds.append(points)
        return points

    def add(self, start: int, outputs: Mapping[str, NDArray[np.float64]]) -> None:
        """Outputs of points ``start, start + 1, ...`` of the current round (in order,
        chunk by chunk; failed runs as NaN rows)."""
        current = self._rounds[-1]
        offset = sum(len(r) for r in self._rounds[:-1])
        if offset + start != self._fed:
            raise RuntimeError(
                f"validation outputs fed out of order ({offset + start} != {self._fed})"
            )
        size = None
        for name, extremes in self._extremes.items():
            values = np.asarray(outputs[name], dtype=float)
            size = len(values)
            extremes.add(offset + start, values, current.level[start : start + size])
            if self._keep:
                self._kept.setdefault(name, []).append(values)
        for row in range(offset + start, offset + start + int(size or 0)):
            if row in self._tracked:
                name, element = self._tracked[row]
                flat = np.asarray(outputs[name], dtype=float).reshape(int(size or 0), -1)
                self._values[row] = float(flat[row - offset - start, element])
        self._fed += int(size or 0)

    # ----------------------------------------------------------------- search
    def _search(self, budget: int) -> ValidationPoints | None:
        """A round of the local search from the points that give each level's bounds
        (validation runs and the plan's runs): a compass step along every parameter,
        then one step to the vertex of the parabolas through those steps."""
        plan = self.plan
        samples = np.concatenate([r.samples for r in self._rounds])
        steps = np.concatenate([r.step for r in self._rounds])  # type: ignore[misc]
        n_plan = len(plan)
        boxes = self._boxes
        # per (level, side): start -> [elements it gives, output, element, its value there]
        score: dict[tuple[int, int], dict[int, list[Any]]] = {}
        interpolated = plan.scheme.interpolates
        for name, extremes in self._extremes.items():
            lower, upper = self._cuts[name]
            lower_from, upper_from = self._bounds_from.get(name, (None, None))
            for side, (own, own_point, cut, cut_from, better) in enumerate(
                (
                    (extremes.low, extremes.low_point, lower, lower_from, np.less),
                    (extremes.high, extremes.high_point, upper, upper_from, np.greater),
                )
            ):
                for j in range(len(plan.levels)):
                    if not np.any(boxes[j, :, 1] > boxes[j, :, 0]):
                        continue  # a crisp core: a single point, nothing to search
                    beaten = better(own[j], cut[j]) & (own_point[j] >= 0)
                    if interpolated:  # the bounds are no run's: follow the best validation run
                        beaten = own_point[j] >= 0
                    start = np.where(beaten, n_plan + own_point[j], -1)
                    value = np.where(beaten, own[j], cut[j])
                    if cut_from is not None:
                        start = np.where(beaten, start, np.asarray(cut_from)[j])
                    elements = np.flatnonzero(start >= 0)
                    target = score.setdefault((j, side), {})
                    for element in elements:
                        entry = target.setdefault(
                            int(start[element]), [0, name, int(element), float(value[element])]
                        )
                        entry[0] += 1
        if not score:
            return self._halton_round(budget)

        def point(index: int) -> NDArray[np.float64]:
            return plan.samples[index] if index < n_plan else samples[index - n_plan]

        ranked: dict[tuple[int, int], list[tuple[int, list[Any]]]] = {}
        for (j, side), entries in score.items():
            low, high = boxes[j, :, 0], boxes[j, :, 1]
            keyed = []
            for index, entry in entries.items():
                x = point(index)
                inner = bool(np.any((x > low) & (x < high)))
                keyed.append((not inner, -entry[0], index, entry))
            ranked[(j, side)] = [(index, entry) for _, _, index, entry in sorted(keyed)]
        # the levels take turns from both ends, both sides of each
        leads: list[tuple[int, int, int, list[Any]]] = []
        rank = 0
        order = zigzag(sorted({j for j, _ in ranked}))
        while any(rank < len(listed) for listed in ranked.values()):
            for j in order:
                for side in (0, 1):
                    listed = ranked.get((j, side), [])
                    if rank < len(listed):
                        leads.append((listed[rank][0], j, side, listed[rank][1]))
            rank += 1
        n = len(plan.names)
        known = {np.round(x, 12).tobytes() for x in np.concatenate([plan.samples, samples])}
        first_new = len(samples)
        new: list[NDArray[np.float64]] = []
        new_steps: list[float] = []
        for index, j, side, (_, name, element, value) in leads:
            if len(new) == budget:
                break
            x = point(index)
            code = (np.round(x, 12).tobytes(), j, side)
            entry = self._expanded.get(code)
            if entry is None:
                step = FIRST_STEP if index < n_plan else float(steps[index - n_plan])
                entry = self._expanded[code] = {"step": step, "tried": {}, "vertex": False}
            elif len(entry["tried"]) == 2 * n and entry["vertex"]:
                entry.update(step=0.5 * entry["step"], tried={}, vertex=False)  # a finer step
            half = 0.5 * (boxes[j, :, 1] - boxes[j, :, 0])
            proposals: list[tuple[NDArray[np.float64], Any]] = []
            if len(entry["tried"]) < 2 * n:
                for i in range(n):
                    for sign in (-1, 1):
                        if (i, sign) in entry["tried"]:
                            continue
                        y = x.copy()
                        y[i] = np.clip(x[i] + sign * entry["step"] * half[i], *boxes[j, i])
                        proposals.append((y, (i, sign)))
            else:
                entry["vertex"] = True
                y = self._vertex(x, entry, name, element, value, side, half, boxes[j])
                if y is not None:
                    proposals.append((y, None))
            for y, direction in proposals:
                if len(new) == budget:
                    break
                code_y = np.round(y, 12).tobytes()
                if direction is not None:
                    # -1: clipped onto x or a known point, no value of its own to fit
                    entry["tried"][direction] = -1
                if code_y in known:
                    continue
                known.add(code_y)
                if direction is not None:
                    entry["tried"][direction] = first_new + len(new)
                    self._tracked[first_new + len(new)] = (name, element)
                new.append(y)
                new_steps.append(entry["step"])
        if not new:
            return None
        table = np.asarray(new, dtype=float)
        return ValidationPoints(
            table,
            box_level(plan, table),
            np.asarray(["search"] * len(table)),
            np.asarray(new_steps, dtype=float),
        )

    def _vertex(
        self,
        x: NDArray[np.float64],
        entry: dict[str, Any],
        name: str,
        element: int,
        value: float,
        side: int,
        half: NDArray[np.float64],
        box: NDArray[np.float64],
    ) -> NDArray[np.float64] | None:
        """The vertex of the parabolas through each parameter's compass steps (per
        parameter, within one step; towards the better step where the curvature is of
        the wrong sign), for the output element the start was chosen for."""
        sign = 1.0 if side == 1 else -1.0  # maximise the upper bound, minimise the lower
        h = entry["step"]
        y = x.copy()
        moved = False
        for i in range(len(x)):
            found = []
            for direction in (-1, 1):
                row = entry["tried"].get((i, direction), -1)
                tracked = self._values.get(row)
                found.append(None if tracked is None else sign * tracked)
            centre = sign * value
            low, high = found
            if low is None or high is None or not np.isfinite(centre):
                better = [d for d, v in ((-1, low), (1, high)) if v is not None and v > centre]
                offset = float(better[0]) if better else 0.0
            else:
                curvature = high - 2.0 * centre + low
                if curvature < 0.0:
                    offset = float(np.clip(0.5 * (low - high) / curvature, -1.0, 1.0))
                elif max(low, high) > centre:
                    offset = 1.0 if high >= low else -1.0
                else:
                    offset = 0.0
            if offset != 0.0:
                y[i] = np.clip(x[i] + offset * h * half[i], *box[i])
                moved = True
        return y if moved else None

    def _halton_round(self, budget: int) -> ValidationPoints:
        """Without any bound to start from: further Halton points."""
        n = len(self.plan.names)
        done = sum(len(r) for r in self._rounds)
        unit = halton(budget, n, start=done, seed=self._seed)
        bottom = self._boxes[0]
        table = bottom[:, 0] + unit * (bottom[:, 1] - bottom[:, 0])
        return ValidationPoints(
            table,
            box_level(self.plan, table),
            np.asarray(["halton"] * budget),
            np.full(budget, FIRST_STEP),
        )

    # ----------------------------------------------------------------- result
    def outcome(self) -> SearchOutcome:
        """What the check found, once every round was fed."""
        rounds = self._rounds
        n = len(self.plan.names)
        if rounds:
            points = ValidationPoints(
                np.concatenate([r.samples for r in rounds]),
                np.concatenate([r.level for r in rounds]),
                np.concatenate([r.kind for r in rounds]),
                np.concatenate([r.step for r in rounds]),  # type: ignore[misc]
            )
        else:
            points = ValidationPoints(
                np.empty((0, n)), np.empty(0, np.int64), np.empty(0, "<U6"), np.empty(0)
            )
        error = float("nan")
        per_output: dict[str, float] = {}
        worst: dict[str, Any] | None = None
        excursion: dict[str, NDArray[np.float64]] = {}
        low: dict[str, NDArray[np.float64]] = {}
        high: dict[str, NDArray[np.float64]] = {}
        for name, extremes in self._extremes.items():
            parts = extremes.point_excursion
            excursion[name] = np.concatenate(parts) if parts else np.empty(0)
            shape = (len(extremes.low), *extremes.shape)
            low[name] = extremes.low.reshape(shape)
            high[name] = extremes.high.reshape(shape)
            miss = extremes.miss()
            if not np.isfinite(miss).any():
                per_output[name] = float("nan")
                continue
            j, element = np.unravel_index(int(np.nanargmax(miss)), miss.shape)
            per_output[name] = float(miss[j, element])
            if not np.isfinite(error) or per_output[name] > error:
                error = per_output[name]
                below = extremes.lower[j, element] - extremes.low[j, element]
                above = extremes.high[j, element] - extremes.upper[j, element]
                source = extremes.low_point if below >= above else extremes.high_point
                worst = {
                    "output": name,
                    "level": int(j),
                    "point": int(source[j, element]),
                    "element": [int(i) for i in np.unravel_index(int(element), extremes.shape)],
                }
        outputs = None
        if self._keep:
            outputs = {
                name: np.concatenate(parts) if parts else np.empty((0,))
                for name, parts in self._kept.items()
            }
        sizes = [len(r) for r in rounds]
        return SearchOutcome(points, error, per_output, worst, excursion, low, high, outputs, sizes)


def _bounding_samples(
    plan: Plan,
    outputs: Mapping[str, NDArray[np.float64]],
    failed: NDArray[np.bool_] | None,
) -> dict[str, tuple[NDArray[np.int64], NDArray[np.int64]]]:
    """Per output, (L, size) the plan sample with the smallest and the largest value in
    each level's box (nested), from the method's outputs."""
    level = box_level(plan, plan.samples)
    usable = np.ones(len(plan), dtype=bool) if failed is None else ~np.asarray(failed, bool)
    found = {}
    for name, values in outputs.items():
        flat = np.asarray(values, dtype=float).reshape(len(plan), -1)
        ok = usable & np.isfinite(flat).all(axis=1)
        levels = len(plan.levels)
        low = np.full((levels, flat.shape[1]), -1, dtype=np.int64)
        high = low.copy()
        for j in range(levels):
            rows = np.flatnonzero(ok & (level >= j))
            if len(rows):
                low[j] = rows[np.argmin(flat[rows], axis=0)]
                high[j] = rows[np.argmax(flat[rows], axis=0)]
        found[name] = (low, high)
    return found


def check_plan(
    plan: Plan,
    model: Callable[[Mapping[str, NDArray[np.float64]]], Mapping[str, NDArray[np.float64]]],
    outputs: Mapping[str, NDArray[np.float64]],
    cuts: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]],
    count: int | None = None,
    failed: NDArray[np.bool_] | None = None,
) -> SearchOutcome:
    """The method check of a plan by hand: every round evaluated with ``model`` at once.

    Parameters
    ----------
    plan : the plan; model : the batched model.
    outputs : output -> (N, ...) the method's outputs.
    cuts : output -> ``(lower, upper)``, the cuts retransformed from them.
    count : validation runs (default :func:`default_validation_count`).
    failed : (N,) the method's failed runs.
    """
    if count is None:
        count = default_validation_count(len(plan), len(plan.names))
    search = MethodSearch(plan, cuts, count, outputs=outputs, failed=failed)
    while (points := search.next_round()) is not None:
        values = model(dict(zip(plan.names, points.samples.T, strict=True)))
        search.add(0, {name: np.asarray(values[name], dtype=float) for name in cuts})
    return search.outcome()
