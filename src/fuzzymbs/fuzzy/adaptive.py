"""The adaptive transformation method: a surrogate refined until its bounds are certified.

One surrogate of every output element at once over the support box: a
dimension-adaptive sparse grid in Chebyshev form
(:mod:`fuzzymbs.fuzzy.chebyshev_grid`) plus a kernel correction through the
residuals of every run off the grid (:mod:`fuzzymbs.fuzzy.residual_correction`),
so that it takes the model's value at every run. It is refined round by round
where the cut bounds are decided; each cut's lower and upper bound per element
is the surrogate's minimum and maximum over the cut box
(:mod:`fuzzymbs.fuzzy.box_search`), and the true model checks them.

A round (:meth:`AdaptiveTransformation.next_batch`, then :meth:`~AdaptiveTransformation.add`):

1. the surrogate ``s`` of every run so far gives, per level j, element e and
   bound, the extremal point ``x*`` and value (and, once there is a correction,
   the sparse grid alone its own extremal points: where the correction moved an
   extremum);
2. the batch holds (a) the nodes of the forward neighbours of the frontier
   indices whose surplus matters most at the extremal points (refinement where
   the bounds are decided), (b) up to ``4 n`` of those extremal points that lie
   far from every run, the most doubtful first: largest frontier surpluses plus
   correction there, on the cut-width scale (certification), (c) a point of a
   fixed Halton sequence far from every run (exploration);
3. the model's outputs at the batch are compared with ``s``: the certified error
   is the larger of how far the bounds moved and how far the error
   ``|f(x) - s(x)|`` seen at the certification and exploration runs could carry
   a value beyond the bounds, per element on the cut-width scale of the highest
   level whose box holds ``x``
   (:func:`~fuzzymbs.fuzzy.band_scale.width_relative`); every run joins the
   surrogate (the nodes its sparse grid, the others its correction).

The loop ends when the certified error of a round is at most ``tolerance`` (after at
least one certification round) or when the next round would exceed ``max_runs``
(:attr:`AdaptiveTransformation.converged` False). The reported bounds are those of
the surrogate of every run, widened to every run inside the box: true values where
a run went beyond, surrogate bounds confirmed within the error estimate elsewhere.

With the model's gradients (``add(points, outputs, gradients)``) the correction also
interpolates the residual gradients at every run, grid nodes included
(:mod:`fuzzymbs.fuzzy.hermite_correction`), and the sparse grid its nodes' derivatives
along one well-resolved direction (:mod:`fuzzymbs.fuzzy.adaptive_gradients`); without
them nothing changes.

Everything is a deterministic function of the outputs added so far (no random
numbers), so replaying stored outputs rebuilds the same rounds bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import ModelOutputError
from fuzzymbs.fuzzy.adaptive_gradients import GradientRounds
from fuzzymbs.fuzzy.adaptive_noise import TWIN, NoiseRule
from fuzzymbs.fuzzy.band_scale import CERTIFIED, WIDTH_FLOOR
from fuzzymbs.fuzzy.box_search import box_extremes
from fuzzymbs.fuzzy.chebyshev_grid import (
    ChebyshevSparseGrid,
    basis_matrix,
    evaluate_series,
    node_values,
)
from fuzzymbs.fuzzy.extremum_confirmation import confirmation_probes
from fuzzymbs.fuzzy.grids import nearest_distances, unique_rows
from fuzzymbs.fuzzy.halton import halton
from fuzzymbs.fuzzy.hermite_correction import flatten_gradients, hermite_correction
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.residual_correction import KernelCorrection

__all__ = ["CERTIFICATES", "NOISE", "AdaptiveOutcome", "AdaptiveTransformation"]

#: extremal points closer than this to a run (unit cube [-1, 1]^n, max norm) are not re-run
_NEAR = 0.02
#: frontier indices whose indicator is within this factor of the largest are refined together
_REFINE_SHARE = 0.8
#: Halton candidates for exploration points per parameter
_EXPLORE_POOL = 512
#: the statuses of :attr:`AdaptiveOutcome.status`
CONVERGED, BUDGET, NOISE = "converged", "budget", "noise"
#: what the certified error may cover (the engine's ``certify``): the bounds or the
#: surrogate wherever it is checked
CERTIFICATES = ("bounds", "global")

#: a surrogate: the sparse grid's Chebyshev series (degrees, coefficients) and the
#: kernel correction through the runs off the grid (None before there are any)
Surrogate = tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None]


@dataclass(frozen=True)
class AdaptiveOutcome:
    """What the adaptive method found.

    Attributes
    ----------
    lower, upper : dict of str to ndarray
        Per output, (L, *shape) nested cut bounds.
    nominal : dict of str to ndarray
        Per output, the value at the modal point.
    error : float
        The certified error estimate of the last round (cut-width scale).
    converged : bool
        ``error <= tolerance``; False when ``max_runs`` stopped the loop.
    runs, rounds : int
        Model runs and rounds.
    pair_sum : dict of str to ndarray
        Per output, (n, L, E) corner sums of the surrogate at every cut box's
        corners (``sum_s sign_i(s) s(corner_s) / 2^(n-1)``): the gain factors' numerators.
    bound : str
        :data:`~fuzzymbs.fuzzy.band_scale.CERTIFIED`: ``error`` is the estimate the
        refinement certifies, not a sampled check's lower bound.
    noise : float
        The model's own noise on the cut-width scale: the largest spread between a twin
        run and the surrogate through its neighbour, 1e-4 of the support's width away
        (NaN when the error never stalled, so no twin ran).
    status : {"converged", "budget", "noise"}
        Why the rounds stopped: the tolerance was reached, the budget was spent, or the
        error stalled and never got below twice the model's noise (refinement cannot
        remove it).
    """

    lower: dict[str, NDArray[np.float64]]
    upper: dict[str, NDArray[np.float64]]
    nominal: dict[str, NDArray[np.float64]]
    error: float
    converged: bool
    runs: int
    rounds: int
    pair_sum: dict[str, NDArray[np.float64]]
    bound: str = CERTIFIED
    noise: float = float("nan")
    status: str = CONVERGED


class AdaptiveTransformation(NoiseRule, GradientRounds):
    """The adaptive method's state machine; pure, no model and no I/O.

    Parameters
    ----------
    parameters : mapping of str to FuzzyNumber
        Fuzzy parameters (their order fixes the point columns).
    levels : ndarray (L,)
        Membership levels from 0 to 1.
    tolerance : float
        Certified error (cut-width scale) at which the loop stops.
    max_runs : int
        Run budget (at least the first round's ``2 n + 2``).
    search_points : int
        Search-grid points per cut box on the surrogate.
    certify : {"bounds", "global"}
        What the certified error covers: ``"bounds"`` (default) the surrogate's error
        where it can carry a value beyond a bound, one exploration point a round;
        ``"global"`` also its error itself at every run off the grid, on the support
        level's cut widths, with ``n`` exploration points a round (for a model whose
        bounds may hide where the surrogate never predicted one; docs/fuzzy.md).
        The options as :class:`~fuzzymbs.fuzzy.methods.adaptive.Adaptive` declares and
        checks them (its :meth:`~fuzzymbs.fuzzy.methods.adaptive.Adaptive.start` makes the
        engine).

    Notes
    -----
    Use: ``while not engine.done: points = engine.next_batch(); engine.add(points,
    model(points))``, then :meth:`outcome`. :meth:`next_batch` is idempotent until
    :meth:`add`; :meth:`add` takes the outputs of exactly that batch.
    """

    def __init__(
        self,
        parameters: Mapping[str, FuzzyNumber],
        levels: NDArray[np.float64],
        tolerance: float,
        max_runs: int,
        search_points: int,
        certify: str = "bounds",
    ) -> None:
        if certify not in CERTIFICATES:
            allowed = " or ".join(f'"{name}"' for name in CERTIFICATES)
            raise ValueError(f"certify must be {allowed}, got {certify!r}")
        self.names = tuple(parameters)
        self.certify = certify
        self.levels = np.asarray(levels, dtype=float)
        self.tolerance, self.max_runs = float(tolerance), int(max_runs)
        self.search_points = int(search_points)
        cuts = np.stack([parameters[n].cuts(self.levels) for n in self.names], axis=1)
        self.cut_lower = cuts[:, :, 0]
        self.cut_upper = cuts[:, :, 1]
        self._low = self.cut_lower[0]
        self._high = self.cut_upper[0]
        self._modal = np.array([parameters[n].modal for n in self.names], dtype=float)
        frozen = [i for i in range(len(self.names)) if not self._high[i] > self._low[i]]
        self.grid = ChebyshevSparseGrid(len(self.names), frozen)
        dimension = len(self.names)
        self._box_low = self.to_unit(self.cut_lower)
        self._box_high = self.to_unit(self.cut_upper)
        self._pool = 2.0 * halton(_EXPLORE_POOL * dimension, dimension, start=1) - 1.0
        self._explore = dimension if certify == "global" else 1  # exploration points a round
        # evaluated runs
        self.samples = np.empty((0, dimension))
        self._units = np.empty((0, dimension))
        self._values: NDArray[np.float64] | None = None
        self._off_grid = np.empty(0, dtype=np.intp)  # runs that are no grid node
        # the model's gradients (N, E, n) in unit coordinates and which runs have one
        self._slopes: NDArray[np.float64] | None = None
        self._sloped = np.empty(0, dtype=bool)
        self._layout: dict[str, tuple[int, tuple[int, ...]]] = {}
        # round state
        self.rounds = 0
        self.error = np.inf
        self.errors: list[float] = []
        self.done = False
        self.converged = False
        self.status = ""
        # twin runs (measure the model's noise, never enter the surrogate) and their spreads
        self._twins = np.empty(0, dtype=np.intp)
        self.noise = float("nan")
        self._pending: tuple[NDArray[np.float64], list[tuple[int, ...] | str | None]] | None = None
        self._surrogate: Surrogate | None = None
        self._bounds: tuple[NDArray, NDArray, NDArray, NDArray] | None = None
        self._certified = False
        #: the last round proposed confirms the extrema on the model: the rounds end after it
        #: unless it finds what the surrogate missed (a study checks its time integration meanwhile)
        self.confirming = False
        #: a first-order gap above the tolerance that no step could close (first_order.py),
        #: or a confirmation round that found the surrogate off: the grid is refined next
        self._open_gap = False
        # extremal points (arg_lower, arg_upper) of the sparse grid without the correction
        self._rivals: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    # ------------------------------------------------------------- coordinates
    def to_unit(self, points: ArrayLike) -> NDArray[np.float64]:
        """Parameter points (..., n) to the unit cube [-1, 1]^n of the support box."""
        values = np.asarray(points, dtype=float)
        width = self._high - self._low
        safe = np.where(width > 0.0, width, 1.0)
        return np.where(width > 0.0, 2.0 * (values - self._low) / safe - 1.0, 0.0)

    def to_parameters(self, unit: ArrayLike) -> NDArray[np.float64]:
        """Points of [-1, 1]^n to the support box (-1 and 1 map exactly onto its bounds)."""
        t = (np.asarray(unit, dtype=float) + 1.0) / 2.0
        return np.where(self._high > self._low, self._low * (1.0 - t) + self._high * t, self._modal)

    # ------------------------------------------------------------------ rounds
    @property
    def runs(self) -> int:
        """Model runs added so far."""
        return len(self.samples)

    def next_batch(self) -> NDArray[np.float64]:
        """The points (B, n) of the next round; (0, n) once done."""
        if self.done:
            return np.empty((0, len(self.names)))
        if self._pending is None:
            self._pending = self._plan_round()
            if len(self._pending[0]) == 0:
                if not self.done:  # nothing left to refine within the budget
                    self._finish(converged=False)
                return np.empty((0, len(self.names)))
        return self._pending[0].copy()

    def add(
        self,
        points: ArrayLike,
        outputs: Mapping[str, ArrayLike],
        gradients: Mapping[str, ArrayLike] | None = None,
    ) -> None:
        """The model's outputs at the batch of :meth:`next_batch` (same points, same order),
        and optionally their gradients ``{name: (B, *shape, n)}`` with respect to the
        parameters (in the parameters' units, last axis in :attr:`names` order): the
        surrogate then interpolates them too (:mod:`fuzzymbs.fuzzy.hermite_correction`).

        Raises
        ------
        ModelOutputError
            Points other than the batch's, outputs or gradients of the wrong shape, or
            non-finite values (the surrogate needs every run).
        """
        if self._pending is None:
            raise ModelOutputError("add() needs the batch of next_batch() first")
        batch, nodes = self._pending
        given = np.asarray(points, dtype=float)
        if given.shape != batch.shape or not np.array_equal(given, batch):
            raise ModelOutputError("add() takes the outputs at exactly the points of next_batch()")
        flat = self._flatten(outputs, len(batch))
        if gradients is not None or self._slopes is not None:
            half = (self._high - self._low) / 2.0
            slopes = (
                np.zeros((len(batch), flat.shape[1], len(half)))
                if gradients is None
                else flatten_gradients(gradients, self._layout, len(batch), half)
            )
            known = (
                self._slopes
                if self._slopes is not None
                else np.zeros((self.runs, *slopes.shape[1:]))
            )
            before = self._sloped if self._slopes is not None else np.zeros(self.runs, dtype=bool)
            self._slopes = np.concatenate((known, slopes))
            self._sloped = np.concatenate((before, np.full(len(batch), gradients is not None)))
        self._last_batch = self.runs + np.arange(len(batch))
        self._last_predicted = (
            np.zeros_like(flat)
            if self._surrogate is None
            else self._predict(self._surrogate, self.to_unit(batch))
        )
        fresh = [(q, row) for row, q in enumerate(nodes) if isinstance(q, tuple)]
        if fresh:
            rows = [row for _, row in fresh]
            given = None if gradients is None else slopes[rows]
            self.grid.set_values([q for q, _ in fresh], flat[rows], given)
        self.samples = np.concatenate((self.samples, batch))
        self._units = np.concatenate((self._units, self.to_unit(batch)))
        self._values = flat if self._values is None else np.concatenate((self._values, flat))
        self._pending = None
        self.rounds += 1
        first = self.runs - len(batch)
        self._off_grid = np.concatenate(
            (self._off_grid, first + np.flatnonzero([q is None for q in nodes]))
        )
        twins = first + np.flatnonzero([q == TWIN for q in nodes])
        if len(twins):
            self._twins = np.concatenate((self._twins, twins))
            spread = self._spread(twins - first)
            self.noise = spread if np.isnan(self.noise) else max(self.noise, spread)

    def _flatten(self, outputs: Mapping[str, ArrayLike], count: int) -> NDArray[np.float64]:
        """Outputs as one (B, E) matrix; the layout is fixed by the first batch."""
        if not isinstance(outputs, Mapping) or not outputs:
            raise ModelOutputError("outputs must be a non-empty dict {name: (B, ...) array}")
        if not self._layout:
            offset = 0
            for name, value in outputs.items():
                shape = np.shape(value)[1:]
                self._layout[name] = (offset, shape)
                offset += int(np.prod(shape, dtype=np.int64))
        if set(outputs) != set(self._layout):
            raise ModelOutputError(
                f"outputs changed between rounds: {sorted(self._layout)} then {sorted(outputs)}"
            )
        parts = []
        for name, (_, shape) in self._layout.items():
            value = np.asarray(outputs[name], dtype=float)
            if value.shape != (count, *shape):
                raise ModelOutputError(
                    f"output {name!r} must have shape {(count, *shape)}, got {value.shape}"
                )
            if not np.all(np.isfinite(value)):
                raise ModelOutputError(
                    f"output {name!r} has NaN or inf: every run of the adaptive method enters "
                    "its surrogate, so none may fail"
                )
            parts.append(value.reshape(count, -1))
        return np.concatenate(parts, axis=1)

    # ---------------------------------------------------------------- planning
    def _plan_round(self) -> tuple[NDArray[np.float64], list[tuple[int, ...] | str | None]]:
        """Points of the next round and, per point, its grid node (None: off the grid)."""
        dimension = len(self.names)
        if self.rounds == 0:
            nodes: list[tuple[int, ...]] = []
            start = (0,) * dimension
            nodes += self.grid.add_index(start)
            for i in range(dimension):
                step = tuple(1 if q == i else 0 for q in range(dimension))
                if self.grid.admissible(step):
                    nodes += self.grid.add_index(step)
            units = node_values(np.array(nodes, dtype=np.int64))
            points = self.to_parameters(units)
            labels: list[tuple[int, ...] | str | None] = list(nodes)
            modal_unit = self.to_unit(self._modal)
            # a node that is the modal point up to round-off of the unit map is run there
            same = np.all(np.abs(units - modal_unit) <= 1e-12, axis=1)
            points[same] = self._modal
            units[same] = modal_unit
            if not np.any(np.all(units == modal_unit, axis=1)):
                points = np.concatenate((self._modal[None, :], points))
                labels = [None, *labels]
            else:  # the modal point first: sample 0 of every plan is the nominal one
                first = int(np.flatnonzero(np.all(units == modal_unit, axis=1))[0])
                order = [first, *[i for i in range(len(points)) if i != first]]
                points, labels = points[order], [labels[i] for i in order]
            return points, labels
        surrogate = self._build_surrogate()
        bounds = self._search(surrogate)
        if self._bounds is not None:
            before = self._reported
            self._surrogate, self._bounds = surrogate, bounds
            self.error = self._certified_error(before)
            self.errors.append(self.error)
            steps, gap = np.empty((0, dimension)), 0.0
            if self._certified and self.error <= self.tolerance:
                # with the model's gradients, the steps of the extrema whose first-order
                # conditions fail (first_order.py); a gap no step can close: refine on
                steps, gap = self._first_order(surrogate, bounds, _NEAR)
                if gap > self.tolerance and not len(steps):
                    self.error, self._open_gap = gap, True
            if self._certified and self.error <= self.tolerance:
                # then one round confirms the extrema on the model (extremum_confirmation.py)
                left = self.max_runs - self.runs
                room = 0 if self.confirming else min(4 * dimension, left)
                ties = 0 if self.confirming else max(min(dimension, left - room), 0)
                probes = confirmation_probes(
                    surrogate, *bounds[2:], self._box_low, self._box_high, self._scale(),
                    np.concatenate((self._units, steps)), self._high > self._low, near=_NEAR,
                    limit=max(room - len(steps), 0),
                    tie_limit=ties, isolated_limit=max(min(dimension, left - room - ties), 0),
                )  # fmt: skip
                probes = np.concatenate((steps, probes))
                self.error = max(*self.errors[-2 if self.confirming else -1 :], gap)
                self.confirming = len(probes) > 0
                if self.confirming:
                    self._reported = self._widened()
                    return self.to_parameters(probes), [None] * len(probes)
                self._finish(converged=True)
                return np.empty((0, dimension)), []
            # a confirmation that found the surrogate off: refine (adaptive_gradients.py)
            self._open_gap = self._open_gap or self.confirming
            self.confirming = False
            if self._noise_limited():
                self._finish(converged=False, status=NOISE)
                return np.empty((0, dimension)), []
        self._surrogate, self._bounds = surrogate, bounds
        self._reported = self._widened()
        scale = self._scale()
        self._rivals = None
        if surrogate[2] is not None:
            # where the sparse grid alone puts the extremes: candidates the correction moved
            rival = box_extremes(
                surrogate[0], surrogate[1], self._box_low, self._box_high, budget=self.search_points
            )
            self._rivals = rival[2], rival[3]
        doubt = self._doubt(scale, surrogate[2])
        refine = [] if self._settled() else self._refinement(scale)
        nodes = []
        for index in refine:
            nodes += self.grid.add_index(index)
        node_units = (
            node_values(np.array(nodes, dtype=np.int64)) if nodes else np.empty((0, dimension))
        )
        room = self.max_runs - self.runs - len(nodes)
        extra = self._certification_points(node_units, max(room, 0), doubt)
        self._certified = len(extra) > 0 or self._certified
        units = np.concatenate((node_units, extra))
        if self.runs + len(units) > self.max_runs:
            # over budget: give the refinement back and stop
            for index in refine:
                self._drop_index(index)
            return np.empty((0, dimension)), []
        labels: list[tuple[int, ...] | str | None] = [*nodes, *([None] * len(extra))]
        if self._stalled():
            twins = self._twin_points(self.max_runs - self.runs - len(units))
            units = np.concatenate((units, twins))
            labels += [TWIN] * len(twins)
        return self.to_parameters(units), labels

    def _drop_index(self, index: tuple[int, ...]) -> None:
        self.grid.remove_index(index)

    def _build_surrogate(self) -> Surrogate:
        """The sparse grid's series and, once there are runs off the grid, the kernel
        correction through their residuals (:mod:`fuzzymbs.fuzzy.residual_correction`)."""
        self._choose_hermite()  # with the model's gradients (adaptive_gradients.py)
        degrees, coefficients = self.grid.series()
        sloped = self._slopes is not None and bool(self._sloped.any())
        if not len(self._off_grid) and not sloped:
            return degrees, coefficients, None
        assert self._values is not None
        if sloped:  # values and gradients at every run but the twins
            keep = np.setdiff1d(np.arange(self.runs), self._twins)
            nodes = ~np.isin(np.arange(self.runs), self._off_grid)
            assert self._slopes is not None
            # the last round's factorised system, bordered by this round's runs
            previous = None if self._surrogate is None else self._surrogate[2]
            return degrees, coefficients, hermite_correction(
                degrees, coefficients, self._units[keep], self._values[keep], nodes[keep],
                self._slopes[keep], self._sloped[keep], self._high > self._low, previous,
            )  # fmt: skip
        residuals = self._values - evaluate_series(degrees, coefficients, self._units)
        residuals[np.setdiff1d(np.arange(self.runs), self._off_grid)] = 0.0  # nodes: round-off
        # twins stay out: two runs 1e-4 of the support apart with a noisy difference would
        # make the interpolant swing; they only measure the noise
        keep = np.setdiff1d(np.arange(self.runs), self._twins)
        correction = KernelCorrection(self._units[keep], residuals[keep], self._high > self._low)
        return degrees, coefficients, correction

    @staticmethod
    def _predict(surrogate: Surrogate, units: NDArray[np.float64]) -> NDArray[np.float64]:
        """(P, E) the surrogate at points of the unit cube."""
        degrees, coefficients, correction = surrogate
        values = evaluate_series(degrees, coefficients, units)
        return values if correction is None else values + correction.values(units)

    def _search(self, surrogate: Surrogate) -> tuple[NDArray, ...]:
        """Surrogate bounds and extremal points per level box (unit coordinates); a box
        that is a point (a triangular core) is the modal run's value exactly."""
        degrees, coefficients, correction = surrogate
        lower, upper, arg_lower, arg_upper = box_extremes(
            degrees,
            coefficients,
            self._box_low,
            self._box_high,
            budget=self.search_points,
            correction=correction,
        )
        assert self._values is not None
        for j in np.flatnonzero(np.all(self.cut_lower == self.cut_upper, axis=1)):
            lower[j] = upper[j] = self._values[0]  # run 0 is the modal point
        return lower, upper, arg_lower, arg_upper

    def _scale(self) -> NDArray[np.float64]:
        """(L, E) the cut-width scale ``max(w, 0.1 max_e w)`` of the current bounds, the
        maximum over the elements of each output on its own (outputs of different sizes,
        a pad's micrometres beside a caliper's nanometres, are each read on their own
        cut widths); inf where an output's cut has no width at a level (a crisp cut has
        nothing to miss)."""
        lower, upper = self._widened()
        width = upper - lower
        widest = np.empty_like(width)
        for offset, shape in self._layout.values():
            part = slice(offset, offset + int(np.prod(shape, dtype=np.int64)))
            widest[:, part] = width[:, part].max(axis=1, keepdims=True)
        scale = np.maximum(width, WIDTH_FLOOR * widest)
        return np.where(widest > 0.0, scale, np.inf)

    def _widened(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Surrogate bounds widened to every run inside each box, nested."""
        assert self._bounds is not None and self._values is not None
        lower, upper = self._bounds[0].copy(), self._bounds[1].copy()
        for j in range(len(self.levels)):
            inside = np.all(
                (self.samples >= self.cut_lower[j]) & (self.samples <= self.cut_upper[j]), axis=1
            )
            if inside.any():
                lower[j] = np.minimum(lower[j], self._values[inside].min(axis=0))
                upper[j] = np.maximum(upper[j], self._values[inside].max(axis=0))
        lower = np.minimum.accumulate(lower[::-1], axis=0)[::-1]
        upper = np.maximum.accumulate(upper[::-1], axis=0)[::-1]
        return lower, upper

    def _levels_holding(self, units: NDArray[np.float64]) -> NDArray[np.intp]:
        """(P,) the highest level whose box holds each point (unit coordinates)."""
        eps = 1e-12
        inside = np.all(
            (units[:, None, :] >= self._box_low[None] - eps)
            & (units[:, None, :] <= self._box_high[None] + eps),
            axis=2,
        )  # (P, L); level 0 holds every point
        return len(self.levels) - 1 - np.argmax(inside[:, ::-1], axis=1)

    def _certified_error(self, before: tuple[NDArray, NDArray]) -> float:
        """The certified error of the current bounds: how far they moved since the last
        round's (both widened to every run), and how far the surrogate's error seen at the
        runs off the grid could carry a value beyond them (:meth:`_relevant_miss`), on the
        cut-width scale."""
        assert self._values is not None and self._surrogate is not None
        lower, upper = self._widened()
        scale = self._scale()
        moved = (np.abs(lower - before[0]) + np.abs(upper - before[1])) / scale
        change = float(np.max(np.where(np.isfinite(scale), moved, 0.0)))
        # the certification: the runs of the last round off the grid (extremal and
        # exploration points) against the surrogate they were planned with
        batch = self._last_batch
        off = np.isin(batch, self._off_grid)
        seen = self._relevant_miss(
            self._units[batch[off]], self._values[batch[off]], self._last_predicted[off]
        )
        return max(change, float(seen.max(initial=0.0)))

    def _relevant_miss(
        self, units: NDArray[np.float64], values: NDArray[np.float64], predicted: NDArray
    ) -> NDArray[np.float64]:
        """(P,) per point the largest ``(s + |f - s| - U)_+ + (L - s + |f - s|)_+`` over the
        levels whose box holds it and the elements, on the cut-width scale: how far the
        surrogate's error seen at the point could carry a value beyond the surrogate's
        bounds ``[L, U]`` (at an extremal point: the error itself)."""
        lower, upper = self._widened()
        scale = self._scale()
        error = np.abs(values - predicted)
        holding = self._levels_holding(units)
        worst = np.zeros(len(units))
        for j in range(len(self.levels)):
            inside = holding >= j
            if not inside.any() or not np.any(np.isfinite(scale[j])):
                continue
            s, e = predicted[inside], error[inside]
            beyond = np.maximum(s + e - upper[j], 0.0) + np.maximum(lower[j] - s + e, 0.0)
            relative = np.where(np.isfinite(scale[j]), beyond / scale[j], 0.0)
            worst[inside] = np.maximum(worst[inside], relative.max(axis=1))
        if self.certify == "global" and np.any(np.isfinite(scale[0])):
            # the surrogate's error itself on the support's cut widths: a feature it never
            # predicted (an edge, a corner's flank) shows there before it moves a bound
            relative = np.where(np.isfinite(scale[0]), error / scale[0], 0.0)
            worst = np.maximum(worst, relative.max(axis=1))
        return worst

    def _refinement(self, scale: NDArray[np.float64]) -> list[tuple[int, ...]]:
        """Forward neighbours of the frontier indices whose surplus at the extremal points
        (on the cut-width scale of their level) is within a factor of the largest."""
        assert self._bounds is not None
        _, _, arg_low, arg_high = self._bounds
        count_levels, elements, dimension = arg_low.shape
        points = np.concatenate((arg_low.reshape(-1, dimension), arg_high.reshape(-1, dimension)))
        element = np.tile(np.arange(elements), 2 * count_levels)
        level = np.tile(np.repeat(np.arange(count_levels), elements), 2)
        weight = 1.0 / scale[level, element]
        # the runs off the grid: where the surrogate is checked
        off = self._off_grid
        if len(off):
            holding = self._levels_holding(self._units[off])
            count_off = len(off)
            points = np.concatenate((points, np.repeat(self._units[off], elements, axis=0)))
            element = np.concatenate((element, np.tile(np.arange(elements), count_off)))
            level = np.repeat(holding, elements)
            weight = np.concatenate(
                (
                    weight,
                    1.0
                    / scale[np.minimum(level, len(scale) - 2), element[-count_off * elements :]],
                )
            )
        unique, inverse = unique_rows(points, sort=True)
        indicator: dict[tuple[int, ...], float] = {}
        for index in self.grid.active:
            degrees, coefficients = self.grid.surplus(index)
            values = basis_matrix(degrees, unique)[inverse.ravel()]  # (K, D)
            local = np.einsum("kd,dk->k", values, coefficients[:, element])
            goal = float(np.nanmax(np.abs(local) * weight))
            # the surplus anywhere in the support box (its coefficients' sum bounds it)
            anywhere = float(np.max(np.abs(coefficients).sum(axis=0) / scale[0]))
            indicator[index] = max(goal, 0.1 * anywhere)
        if not indicator:
            return []
        largest = max(indicator.values())
        chosen: list[tuple[int, ...]] = []
        for index in self.grid.active:
            if indicator[index] >= _REFINE_SHARE * largest and indicator[index] > 0.0:
                self.grid.expanded.add(index)
                for forward in self.grid.forward(index):
                    if forward not in chosen and all(
                        back in self.grid or back in chosen for back in _backward(forward)
                    ):
                        chosen.append(forward)
        return chosen

    def _extremal_points(self) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
        """Every extremal point (K, n) of the current bounds, and of the sparse grid alone
        once a correction moved them, with its level and element."""
        assert self._bounds is not None
        _, _, arg_low, arg_high = self._bounds
        count_levels, elements, dimension = arg_low.shape
        sets = [arg_low, arg_high]
        if self._rivals is not None:
            sets += list(self._rivals)
        points = np.concatenate([a.reshape(-1, dimension) for a in sets])
        level = np.tile(np.repeat(np.arange(count_levels), elements), len(sets))
        element = np.tile(np.arange(elements), len(sets) * count_levels)
        return points, level, element

    def _doubt(
        self, scale: NDArray[np.float64], correction: KernelCorrection | None
    ) -> NDArray[np.float64]:
        """(K,) per extremal point (order of :meth:`_extremal_points`) how far the surrogate
        there may still be off, on the cut-width scale of its level: the frontier's
        surpluses ``sum_k |Delta_k(x)|`` of its own element over the active indices (what
        the next refinement could still add) plus the size of the kernel correction (where
        the runs off the grid already found the sparse grid off)."""
        points, level, element = self._extremal_points()
        unique, inverse = unique_rows(points, sort=True)
        doubt = np.zeros(len(points))
        for index in self.grid.active:
            degrees, coefficients = self.grid.surplus(index)
            values = basis_matrix(degrees, unique)[inverse.ravel()]  # (K, D)
            doubt += np.abs(np.einsum("kd,dk->k", values, coefficients[:, element]))
        if correction is not None:
            doubt += np.abs(correction.at(points, element))
        weight = 1.0 / scale[level, element]
        return np.where(np.isfinite(weight), doubt * weight, 0.0)

    def _certification_points(
        self, planned: NDArray[np.float64], room: int, doubt: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Up to ``4 n`` extremal points, the most doubtful first (``doubt`` per extremal
        point, :meth:`_doubt`), and one exploration point (``n`` when certifying
        globally), each farther than ``_NEAR`` from every run and every point already
        planned; at most ``room``."""
        assert self._bounds is not None
        dimension = len(self.names)
        moving = self._high > self._low
        candidates, _, _ = self._extremal_points()
        # one candidate per location, with its largest doubt
        candidates, inverse = unique_rows(np.round(candidates, 12), sort=True)
        priority = np.zeros(len(candidates))
        np.maximum.at(priority, inverse.ravel(), doubt)
        taken = np.concatenate((self._units, planned))
        chosen: list[NDArray[np.float64]] = []
        limit = min(room, 4 * dimension)

        def distance(points: NDArray, others: NDArray) -> NDArray:
            return nearest_distances(points[:, moving], others[:, moving])

        far = distance(candidates, taken)
        while len(chosen) < limit:
            best = int(np.argmax(np.where(far > _NEAR, priority, -1.0)))
            if far[best] <= _NEAR:
                break
            chosen.append(candidates[best])
            far = np.minimum(far, distance(candidates, candidates[best][None, :]))
        if len(chosen) < room:  # the exploration points, farthest first
            pool_far = distance(self._pool, np.concatenate((taken, *[c[None] for c in chosen])))
            for _ in range(min(self._explore, room - len(chosen))):
                chosen.append(self._pool[int(np.argmax(pool_far))])
                pool_far = np.minimum(pool_far, distance(self._pool, chosen[-1][None, :]))
        return np.array(chosen).reshape(-1, dimension)

    # ----------------------------------------------------------------- result
    @property
    def layout(self) -> dict[str, tuple[int, tuple[int, ...]]]:
        """Per output, its offset in the flattened elements and its own shape."""
        return dict(self._layout)

    def output(self, name: str) -> NDArray[np.float64]:
        """(N, *shape) the outputs ``name`` of every run added."""
        offset, shape = self._layout[name]
        size = int(np.prod(shape, dtype=np.int64))
        assert self._values is not None
        return self._values[:, offset : offset + size].reshape(self.runs, *shape)

    def _finish(self, converged: bool, status: str | None = None) -> None:
        self.done = True
        self.converged = converged
        self.status = status or (CONVERGED if converged else BUDGET)
        self._pending = None

    def outcome(self) -> AdaptiveOutcome:
        """Bounds, certified error, runs and rounds; the surrogate's corner sums."""
        if self._values is None:
            raise ModelOutputError("the adaptive method has no runs yet")
        if self._surrogate is None:  # stopped after the first round: search it now
            self._surrogate = self._build_surrogate()
        if self._bounds is None:
            self._bounds = self._search(self._surrogate)
        lower, upper = self._widened()
        modal_row = int(np.flatnonzero(np.all(self.samples == self._modal, axis=1))[0])
        pairs = self._corner_sums()
        result_lower, result_upper, nominal, pair_sum = {}, {}, {}, {}
        for name, (offset, shape) in self._layout.items():
            size = int(np.prod(shape, dtype=np.int64))
            part = slice(offset, offset + size)
            result_lower[name] = lower[:, part].reshape(len(self.levels), *shape)
            result_upper[name] = upper[:, part].reshape(len(self.levels), *shape)
            nominal[name] = self._values[modal_row, part].reshape(shape)
            pair_sum[name] = pairs[:, :, part]
        return AdaptiveOutcome(
            result_lower,
            result_upper,
            nominal,
            float(self.error),
            bool(self.converged),
            self.runs,
            self.rounds,
            pair_sum,
            noise=float(self.noise),
            status=self.status or (CONVERGED if self.converged else BUDGET),
        )

    def _corner_sums(self) -> NDArray[np.float64]:
        """(n, L, E) ``sum_s sign_i(s) s(corner_s) / 2^(n-1)`` on the surrogate."""
        assert self._surrogate is not None
        dimension = len(self.names)
        bits = (np.arange(2**dimension)[:, None] >> np.arange(dimension - 1, -1, -1)) & 1
        sums = np.empty((dimension, len(self.levels), self._surrogate[1].shape[1]))
        for j in range(len(self.levels)):
            corners = np.where(bits == 1, self._box_high[j], self._box_low[j])
            values = self._predict(self._surrogate, corners)  # (2^n, E)
            sign = 2.0 * bits - 1.0  # (2^n, n)
            sums[:, j] = sign.T @ values / 2 ** (dimension - 1)
        return sums


def _backward(index: tuple[int, ...]) -> list[tuple[int, ...]]:
    return [(*index[:i], k - 1, *index[i + 1 :]) for i, k in enumerate(index) if k > 0]
