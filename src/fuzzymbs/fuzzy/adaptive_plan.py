"""The adaptive method as a plan: rounds of points proposed until the bounds are certified.

``plan(parameters, method="adaptive", levels=m)`` returns an :class:`AdaptivePlan`.
Unlike the fixed methods its points are not known in advance: each round's
points follow from the outputs of the rounds before
(:class:`~fuzzymbs.fuzzy.adaptive.AdaptiveTransformation`). A caller either
drives the rounds (``next_batch`` / ``add``, what a study does with its
executors and store) or lets :meth:`AdaptivePlan.evaluate` do it with a model;
afterwards :attr:`AdaptivePlan.samples` holds every run in round order (row 0 is
the modal point) and :meth:`AdaptivePlan.retransform` gives the certified cuts.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidPlanError, ModelOutputError
from fuzzymbs.fuzzy.adaptive import (
    DEFAULT_ADAPTIVE_MAX_RUNS,
    DEFAULT_ADAPTIVE_TOLERANCE,
    NOISE,
    AdaptiveOutcome,
    AdaptiveTransformation,
    check_adaptive_options,
)
from fuzzymbs.fuzzy.model_calls import evaluate_table
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import checked_parameters, make_levels
from fuzzymbs.fuzzy.plan_size import DEFAULT_MAX_RUNS
from fuzzymbs.fuzzy.retransform import FuzzyResult

__all__ = ["AdaptivePlan", "AdaptiveWarning", "adaptive_plan", "noise_message"]


class AdaptiveWarning(UserWarning):
    """The adaptive method stopped before its error reached the tolerance: at its run budget,
    or because the model's own noise is larger than what refinement can remove."""


def noise_message(runs: int, noise: float, tolerance: float) -> str:
    """The one line that says the model's noise stopped the adaptive method.

    Parameters
    ----------
    runs : int
        Runs the method used.
    noise, tolerance : float
        The measured noise and ``method_tolerance``, on the cut-width scale.

    Returns
    -------
    str
        What stopped the rounds and what to do about it.
    """
    return (
        f"adaptive method stopped after {runs} runs: the model's own noise, about "
        f"{100 * noise:.3g} % of the cut width, exceeds what refinement can remove "
        f"(tolerance {100 * tolerance:.3g} %); integrate more accurately (a converged "
        "integrator or a tighter tolerance) or raise method_tolerance"
    )


class AdaptivePlan:
    """Plan of the adaptive transformation method (see the module docstring).

    Parameters
    ----------
    parameters : mapping of str to FuzzyNumber
        Fuzzy parameters by name (their order fixes the sample columns).
    levels : int or array_like
        ``m`` for mu_j = j/m, or an increasing list from 0 to 1.
    method_tolerance : float
        Certified error at which the rounds stop, on the cut-width scale
        (:func:`~fuzzymbs.fuzzy.band_scale.band_miss`); default 0.01.
    max_runs : int or None
        Run budget (default and None: 2,000); at least ``2 n + 2``.
    search_points : int, optional
        Search-grid points per cut box on the surrogate (default 20,000).

    Attributes
    ----------
    parameters, names, levels, cut_lower, cut_upper
        As for :class:`~fuzzymbs.fuzzy.transform.Plan`.
    method : str
        ``"adaptive"``.
    method_tolerance : float
    max_runs : int

    Raises
    ------
    InvalidPlanError
        Bad levels, parameters that are not fuzzy numbers, a tolerance that is not
        positive, a budget below the first round.
    """

    method = "adaptive"
    nonmonotonic: tuple[str, ...] = ()
    sparse_level = None

    def __init__(
        self,
        parameters: Mapping[str, FuzzyNumber],
        levels: int | ArrayLike = 4,
        *,
        method_tolerance: float = DEFAULT_ADAPTIVE_TOLERANCE,
        max_runs: int | None = DEFAULT_ADAPTIVE_MAX_RUNS,
        search_points: int | None = None,
    ) -> None:
        self.parameters: dict[str, FuzzyNumber] = checked_parameters(parameters)
        self.names: tuple[str, ...] = tuple(self.parameters)
        self.levels = make_levels(levels)
        budget = DEFAULT_ADAPTIVE_MAX_RUNS if max_runs is None else max_runs
        self.method_tolerance, self.max_runs = check_adaptive_options(
            method_tolerance, budget, len(self.names)
        )
        if search_points is None:
            search_points = 20_000
        if (
            isinstance(search_points, bool)
            or not isinstance(search_points, int | np.integer)
            or search_points < 3 ** len(self.names)
        ):
            raise InvalidPlanError(
                f"search_points must be an int >= 3^n = {3 ** len(self.names)}, "
                f"got {search_points!r}"
            )
        self.search_points = int(search_points)
        cuts = np.stack([number.cuts(self.levels) for number in self.parameters.values()], axis=1)
        self.cut_lower: NDArray[np.float64] = cuts[:, :, 0]
        self.cut_upper: NDArray[np.float64] = cuts[:, :, 1]
        self.reset()

    def reset(self) -> None:
        """Start again from the first round (a study replays its stored rounds)."""
        self.engine = AdaptiveTransformation(
            self.parameters, self.levels, self.method_tolerance, self.max_runs, self.search_points
        )
        self._outcome: AdaptiveOutcome | None = None

    # ------------------------------------------------------------------ rounds
    def next_batch(self) -> NDArray[np.float64]:
        """Points (B, n) of the next round; none once the rounds are done."""
        return self.engine.next_batch()

    def add(self, points: ArrayLike, outputs: Mapping[str, ArrayLike]) -> None:
        """The model's outputs ``{name: (B, ...)}`` at the points of :meth:`next_batch`."""
        self._outcome = None
        self.engine.add(points, outputs)

    @property
    def done(self) -> bool:
        """No round is left (converged, or the budget is spent)."""
        return self.engine.done

    def outcome(self) -> AdaptiveOutcome:
        """Cuts, certified error, runs and rounds (once the rounds are done); warns with
        :class:`AdaptiveWarning` if the budget or the model's noise stopped them above the
        tolerance."""
        if not self.engine.done:
            raise ModelOutputError(
                "the adaptive method has rounds left: call next_batch()/add() until "
                "next_batch() returns no point (or use evaluate(model))"
            )
        if self._outcome is None:
            self._outcome = self.engine.outcome()
            if self._outcome.status == NOISE:
                warnings.warn(
                    noise_message(self._outcome.runs, self._outcome.noise, self.method_tolerance),
                    AdaptiveWarning,
                    stacklevel=2,
                )
            elif not self._outcome.converged:
                warnings.warn(
                    f"the adaptive method stopped at its run budget (max_runs = "
                    f"{self.max_runs}, {self._outcome.runs} runs) with a certified error of "
                    f"{self._outcome.error:.3g} of the cut width, above method_tolerance = "
                    f"{self.method_tolerance:g}; raise max_runs to reach the tolerance",
                    AdaptiveWarning,
                    stacklevel=2,
                )
        return self._outcome

    # ----------------------------------------------------------------- samples
    @property
    def samples(self) -> NDArray[np.float64]:
        """(N, n) every run so far in round order; before the first round the modal point."""
        if self.engine.runs == 0:
            return np.array([[number.modal for number in self.parameters.values()]])
        return self.engine.samples

    def __len__(self) -> int:
        return len(self.samples)

    def __repr__(self) -> str:
        return (
            f"AdaptivePlan(parameters={list(self.names)}, levels={len(self.levels)}, "
            f"runs={self.engine.runs}, rounds={self.engine.rounds}, done={self.engine.done})"
        )

    @property
    def nominal_index(self) -> int:
        """Row of ``samples`` holding the all-modal point (the first run)."""
        return 0

    @property
    def points_without_reuse(self) -> int:
        """Runs so far (every run is a distinct point)."""
        return len(self)

    @property
    def level_usage(self) -> NDArray[np.bool_]:
        """(L, N) all True: every run enters the surrogate behind every level."""
        return np.ones((len(self.levels), len(self)), dtype=bool)

    def check_failed(self, failed: ArrayLike | None) -> NDArray[np.bool_]:
        """A validated (N,) failed-sample mask (all False for None)."""
        if failed is None:
            return np.zeros(len(self), dtype=bool)
        mask = np.asarray(failed)
        if mask.shape != (len(self),) or mask.dtype != np.bool_:
            raise InvalidPlanError(
                f"failed must be a bool array of shape ({len(self)},), got dtype "
                f"{mask.dtype} and shape {mask.shape}"
            )
        return mask

    def levels_touched(self, failed: ArrayLike) -> NDArray[np.bool_]:
        """(L,) every level once any run failed (the surrogate needs every run)."""
        return np.full(len(self.levels), bool(np.any(self.check_failed(failed))))

    def sample_columns(self) -> dict[str, NDArray[np.float64]]:
        """Samples as ``{name: (N,) array}``."""
        return {name: self.samples[:, i].copy() for i, name in enumerate(self.names)}

    # --------------------------------------------------------------- evaluate
    def evaluate(
        self,
        model: Callable[[dict[str, NDArray[np.float64]]], Mapping[str, Any]],
        chunk_size: int | None = None,
    ) -> dict[str, NDArray]:
        """Run every round with ``model`` (``chunk_size`` samples per call) from the first
        (:func:`~fuzzymbs.fuzzy.model_calls.evaluate_table`: the same checks of the model's
        outputs as :meth:`Plan.evaluate <fuzzymbs.fuzzy.transform.Plan.evaluate>`).

        Returns
        -------
        dict of str to ndarray
            Every output at every run, leading axis N in round order (row 0 the modal point).
        """
        self.reset()
        pieces: dict[str, list[NDArray]] = {}
        while True:
            points = self.next_batch()
            if len(points) == 0:
                break
            outputs = evaluate_table(model, self.names, points, chunk_size)
            self.add(points, outputs)
            for key, value in outputs.items():
                pieces.setdefault(key, []).append(value)
        return {key: np.concatenate(value) for key, value in pieces.items()}

    def retransform(
        self,
        outputs: ArrayLike | Mapping[str, ArrayLike],
        failed: ArrayLike | None = None,
        *,
        name: str = "output",
        check_monotonic: bool = True,
    ) -> FuzzyResult | dict[str, FuzzyResult]:
        """The certified cuts of the outputs the rounds saw.

        ``outputs`` are those of every run (as :meth:`evaluate` returns them); they are
        checked against the runs the rounds were given. A mapping gives a dict of results,
        a single array the result of the one output of that shape. ``check_monotonic`` is
        accepted for the plans' common signature and has no effect.

        Raises
        ------
        ModelOutputError
            Outputs that are not those of the rounds, or rounds not finished.
        IncompleteResultError
            Failed runs (the surrogate needs every run).
        """
        from fuzzymbs.errors import IncompleteResultError

        mask = self.check_failed(failed)
        if mask.any():
            raise IncompleteResultError(
                f"{int(mask.sum())} of {len(self)} runs of the adaptive method failed; its "
                "surrogate needs every run, so no level can be bounded"
            )
        outcome = self.outcome()
        if isinstance(outputs, Mapping):
            return {key: self._result(key, value, outcome) for key, value in outputs.items()}
        matches = [
            key
            for key, (_, shape) in self.engine.layout.items()
            if (len(self), *shape) == np.shape(outputs)
        ]
        if len(matches) != 1:
            raise ModelOutputError(
                f"output {name!r}: pass the outputs as a dict {{name: array}}; the rounds saw "
                f"{sorted(self.engine.layout)}"
            )
        return self._result(matches[0], outputs, outcome)

    def _result(self, key: str, values: ArrayLike, outcome: AdaptiveOutcome) -> FuzzyResult:
        if key not in outcome.lower:
            raise ModelOutputError(
                f"output {key!r} was not among the outputs the rounds saw: {sorted(outcome.lower)}"
            )
        array = np.asarray(values, dtype=float)
        expected = self.engine.output(key)
        if array.shape != expected.shape or not np.array_equal(array, expected):
            raise ModelOutputError(
                f"output {key!r} differs from the outputs the adaptive rounds were given "
                "(its bounds come from those runs)"
            )
        return FuzzyResult(
            self.levels,
            outcome.lower[key],
            outcome.upper[key],
            nominal=outcome.nominal[key],
            method=self.method,
            _plan=self,
            _sums=(
                outcome.pair_sum[key],
                np.zeros(len(self.levels), dtype=bool),
            ),
        )

    # ------------------------------------------------------------- describing
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description: method, levels, parameters, tolerance, budget, search."""
        return {
            "method": self.method,
            "levels": self.levels.tolist(),
            "parameters": {name: number.to_dict() for name, number in self.parameters.items()},
            "method_tolerance": self.method_tolerance,
            "max_runs": self.max_runs,
            "search_points": self.search_points,
        }

    def fingerprint(self) -> str:
        """SHA-256 of :meth:`to_dict` (the runs follow from it and the model)."""
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()

    def attrs(self) -> dict[str, Any]:
        """Result attributes: ``method_error``, ``method_error_bound`` (``"certified"``),
        ``method_tolerance``, ``method_converged``, ``adaptive_runs``, ``adaptive_rounds``,
        ``adaptive_status`` (``"converged"``, ``"budget"`` or ``"noise"``) and
        ``adaptive_noise`` (the model's noise on the cut-width scale; NaN if not measured)."""
        outcome = self.outcome()
        return {
            "method_error": float(outcome.error),
            "method_error_bound": outcome.bound,
            "method_tolerance": float(self.method_tolerance),
            "method_converged": int(outcome.converged),
            "adaptive_runs": int(outcome.runs),
            "adaptive_rounds": int(outcome.rounds),
            "adaptive_status": outcome.status,
            "adaptive_noise": float(outcome.noise),
        }


def adaptive_plan(
    parameters: Mapping[str, FuzzyNumber],
    levels: int | ArrayLike = 4,
    nonmonotonic: Iterable[str] | None = None,
    *,
    sparse_level: int | None = None,
    search_points: int | None = None,
    max_runs: int | None = DEFAULT_MAX_RUNS,
    method_tolerance: float | None = None,
) -> AdaptivePlan:
    """``plan(parameters, "adaptive", levels, ...)``: the arguments of
    :class:`~fuzzymbs.fuzzy.transform.Plan`, with ``max_runs`` as the run budget (the
    general plan limit's default, and None, mean the adaptive default of 2,000) and
    ``method_tolerance`` (default 1 %).

    Raises
    ------
    InvalidPlanError
        Options of other methods (``nonmonotonic``, ``sparse_level``), or invalid ones.
    """
    if nonmonotonic:
        raise InvalidPlanError(
            f"nonmonotonic={list(nonmonotonic)} is only used by method='extended', not 'adaptive'"
        )
    if sparse_level is not None:
        raise InvalidPlanError("sparse_level is only used by method='sparse', not 'adaptive'")
    budget = DEFAULT_ADAPTIVE_MAX_RUNS if max_runs in (None, DEFAULT_MAX_RUNS) else max_runs
    return AdaptivePlan(
        parameters,
        levels,
        method_tolerance=(
            DEFAULT_ADAPTIVE_TOLERANCE if method_tolerance is None else method_tolerance
        ),
        max_runs=budget,
        search_points=search_points,
    )
