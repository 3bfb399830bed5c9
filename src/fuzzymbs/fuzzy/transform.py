"""Transformation method (Hanss): sampling plans over the alpha-cuts of fuzzy parameters.

A :class:`Plan` holds the unique sample points a model must be evaluated at and
the bookkeeping that says which points belong to which membership level (and,
for the reduced and extended schemes, which corner runs pair up in one
parameter). Retransformation and influence measures use that bookkeeping only.

The methods (general, reduced, extended, grid, sparse, adaptive) are objects
of :mod:`fuzzymbs.fuzzy.methods`, one module each: a plan asks its method
(:attr:`Plan.scheme`) for its samples, its count and its capabilities. A
method that runs in rounds (adaptive) makes a :class:`RoundsPlan`, the variant
of :class:`Plan` whose points come round by round.

Every fixed plan contains the all-modal point (sample 0), evaluated at level m
(for ``"sparse"``: a candidate of every level's search). Identical points are
evaluated once: points are built from the same cut values and merged by exact
floating-point equality.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import (
    IncompleteResultError,
    InvalidPlanError,
    ModelOutputError,
    UnsupportedOperationError,
)
from fuzzymbs.fuzzy.methods.base import Method, to_parameter_space
from fuzzymbs.fuzzy.methods.registry import METHODS as METHOD_TYPES
from fuzzymbs.fuzzy.methods.registry import method_named
from fuzzymbs.fuzzy.model_calls import evaluate_table
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import checked_parameters, make_levels
from fuzzymbs.fuzzy.plan_size import DEFAULT_MAX_RUNS, check_run_limit, run_count
from fuzzymbs.fuzzy.retransform import FuzzyResult, NonMonotonicWarning, retransform
from fuzzymbs.fuzzy.sparse_grid import SparseGrid

__all__ = [
    "ALL_METHODS",
    "DEFAULT_MAX_RUNS",
    "METHODS",
    "NonMonotonicWarning",
    "Plan",
    "RoundsPlan",
    "make_levels",
    "plan",
    "run_count",
]


#: every method :func:`plan` accepts, by its public name (:mod:`fuzzymbs.fuzzy.methods`)
ALL_METHODS: tuple[str, ...] = tuple(METHOD_TYPES)
#: the names of the methods whose samples are known in advance (every method but those in
#: rounds); the registry of every method is :data:`fuzzymbs.fuzzy.methods.METHODS`
METHODS: tuple[str, ...] = tuple(
    name for name, cls in METHOD_TYPES.items() if not cls.runs_in_rounds
)


def _runs_in_rounds(method: Any) -> bool:
    """Whether ``method`` (a name or a method object) runs in rounds."""
    if isinstance(method, Method):
        return method.runs_in_rounds
    return (
        isinstance(method, str) and method in METHOD_TYPES and METHOD_TYPES[method].runs_in_rounds
    )


def _scheme(
    method: str | Method,
    nonmonotonic: Iterable[str] | str | None,
    sparse_level: int | None,
    search_points: int | None,
    method_tolerance: float | None,
    max_runs: int | None,
) -> tuple[Method, int | None]:
    """The method object of a plan request and the run limit the plan is checked against.

    A method named by a string that declares its own ``max_runs`` (its run budget: the
    adaptive method) takes the plan's ``max_runs`` as that budget (the default limit and
    None mean the method's default); for every other method ``max_runs`` is the limit.
    """
    options: dict[str, Any] = {
        "nonmonotonic": nonmonotonic,
        "sparse_level": sparse_level,
        "search_points": search_points,
        "method_tolerance": method_tolerance,
    }
    if (
        isinstance(method, str)
        and method in METHOD_TYPES
        and METHOD_TYPES[method].declares("max_runs")
    ):
        options["max_runs"] = None if max_runs == DEFAULT_MAX_RUNS else max_runs
        return method_named(method, **options), None
    return method_named(method, **options), max_runs


class Plan:
    """Sample points of a transformation method and their level bookkeeping.

    ``plan(...)`` is the same as ``Plan(...)``. Attributes are read-only by convention.
    A method that runs in rounds (adaptive) gives a :class:`RoundsPlan`.

    Parameters
    ----------
    parameters : mapping of str to FuzzyNumber
        Fuzzy parameters by name (their order fixes the sample columns).
    method : {"general", "reduced", "extended", "grid", "sparse", "adaptive"} or Method
        The method by name, or a method object of :mod:`fuzzymbs.fuzzy.methods` holding
        its own options (then none of the options below are given).
    levels : int or array_like
        ``m`` for mu_j = j/m, or an increasing list from 0 to 1.
    nonmonotonic : iterable of str, optional
        Parameters that get interior points (``"extended"`` only).
    sparse_level : int, optional
        ``"sparse"`` only: Smolyak level ``q - n >= 1`` of the sparse grid
        (default 3; the interpolant reproduces polynomials of total degree <=
        sparse_level).
    search_points : int, optional
        ``"sparse"`` only: points of the tensor search grid per cut box,
        ``k = floor(search_points^(1/n))`` per parameter (default
        ``max(20000, 3^n)``; at least ``3^n``); ``"adaptive"``: on its surrogate
        (default 20,000).
    max_runs : int or None, optional
        Refuse the plan, before anything is built, if it needs more model runs
        than this (:func:`run_count`) or its level bookkeeping (levels x runs)
        more than 10 x this; default :data:`DEFAULT_MAX_RUNS` (1,000,000), None:
        no limit. See :func:`~fuzzymbs.fuzzy.plan_size.check_run_limit`. For
        ``method="adaptive"`` (by name) its run budget: this default and None mean
        2,000.
    method_tolerance : float, optional
        ``"adaptive"`` only: the certified error at which its rounds stop (default 0.01).

    Attributes
    ----------
    parameters : dict of str to FuzzyNumber
        The fuzzy parameters, in insertion order.
    names : tuple of str
        Parameter names (column order of ``samples``).
    levels : ndarray, shape (L,)
        Membership levels mu_0 = 0 ... mu_m = 1.
    method : str
        The method's public name (one of :data:`ALL_METHODS`).
    scheme : Method
        The method object: its options and capabilities.
    nonmonotonic : tuple of str
        Parameters with interior points (``"extended"`` only).
    sparse_level, search_points : int or None
        Sparse-grid level ``q - n`` and search points per cut box (``"sparse"``
        only, else None).
    samples : ndarray, shape (N, n)
        Unique sample points; row 0 is the all-modal (nominal) point.
    cut_lower, cut_upper : ndarray, shape (L, n)
        Alpha-cut bounds of every parameter at every level.

    Raises
    ------
    InvalidPlanError
        Unknown method, bad levels, unknown nonmonotonic names, options that are
        invalid or given to a method that does not use them (the message names the
        option), parameters that are not fuzzy numbers.
    PlanTooLargeError
        (an InvalidPlanError) More runs than ``max_runs``; the message gives the
        runs of the reduced, extended and sparse methods and how to raise the limit.

    Examples
    --------
    >>> from fuzzymbs.fuzzy.numbers import Triangular
    >>> p = plan({"k": Triangular(1, 2, 3), "c": Triangular(4, 5, 6), "m": Triangular(7, 8, 9)})
    >>> len(p)
    33
    """

    def __new__(cls, parameters: Any = None, method: Any = "reduced", *args: Any, **kwargs: Any):
        """A method that runs in rounds (adaptive) gives a :class:`RoundsPlan`; every other
        method a :class:`Plan`."""
        if cls is Plan and _runs_in_rounds(method):
            cls = RoundsPlan
        return super().__new__(cls)

    def __init__(
        self,
        parameters: Mapping[str, FuzzyNumber],
        method: str | Method = "reduced",
        levels: int | ArrayLike = 4,
        nonmonotonic: Iterable[str] | None = None,
        *,
        sparse_level: int | None = None,
        search_points: int | None = None,
        max_runs: int | None = DEFAULT_MAX_RUNS,
        method_tolerance: float | None = None,
    ) -> None:
        scheme, limit = _scheme(
            method, nonmonotonic, sparse_level, search_points, method_tolerance, max_runs
        )
        self.parameters: dict[str, FuzzyNumber] = checked_parameters(parameters)
        self.names: tuple[str, ...] = tuple(self.parameters)
        #: the method object: its options and capabilities (:mod:`fuzzymbs.fuzzy.methods`)
        self.scheme: Method = scheme.checked(self.names)
        # the size first, from the method's count: nothing below may allocate a plan too
        # large to run
        check_run_limit(self.parameters, self.scheme, levels, max_runs=limit)
        self.levels = make_levels(levels)
        cuts = np.stack([number.cuts(self.levels) for number in self.parameters.values()], axis=1)
        self.cut_lower: NDArray[np.float64] = cuts[:, :, 0]  # (L, n)
        self.cut_upper: NDArray[np.float64] = cuts[:, :, 1]
        self._start()

    def _start(self) -> None:
        """Build the samples and their bookkeeping (the method's builder)."""
        sampling = self.scheme.build(self.parameters, self.cut_lower, self.cut_upper)
        self.samples: NDArray[np.float64] = sampling.samples
        self._level_index = sampling.level_index
        self._nominal_index = sampling.nominal_index
        self._points_without_reuse = sampling.points_without_reuse
        self._level_usage = sampling.level_usage
        self._corner_index = sampling.corner_index
        self._extras = sampling.extras

    # ----------------------------------------------------------------- options
    @property
    def method(self) -> str:
        """The method's public name."""
        return self.scheme.name

    @property
    def nonmonotonic(self) -> tuple[str, ...]:
        """Parameters with interior points (``"extended"`` only, else empty)."""
        return getattr(self.scheme, "nonmonotonic", ())

    @property
    def sparse_level(self) -> int | None:
        """Sparse-grid level ``q - n`` (``"sparse"`` only, else None)."""
        return getattr(self.scheme, "sparse_level", None)

    @property
    def search_points(self) -> int | None:
        """Search points per cut box (methods that search cut boxes, else None)."""
        return getattr(self.scheme, "search_points", None)

    # ------------------------------------------------------- interpolating plans
    def to_parameter_space(self, unit_points: ArrayLike) -> NDArray[np.float64]:
        """Map points of the unit cube [0, 1]^n to the support box (the mu = 0 cut)."""
        return to_parameter_space(unit_points, self.cut_lower[0], self.cut_upper[0])

    def to_unit_cube(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map parameter points (P, n) of the support box to [0, 1]^n.

        A parameter with a zero-width support maps to 0.5 (every node has the
        same value there, so the interpolant does not depend on it).
        """
        values = np.asarray(points, dtype=float)
        low, high = self.cut_lower[0], self.cut_upper[0]
        width = high - low
        safe = np.where(width > 0.0, width, 1.0)
        unit = np.where(width > 0.0, (values - low) / safe, 0.5)
        return np.clip(unit, 0.0, 1.0)

    @property
    def sparse_grid(self) -> SparseGrid:
        """The :class:`~fuzzymbs.fuzzy.sparse_grid.SparseGrid` of a sparse plan (unit cube)."""
        self._require_interpolant("sparse_grid")
        return self._extras["sparse_grid"]

    @property
    def node_index(self) -> NDArray[np.intp]:
        """(N_nodes,) sample index of every sparse-grid node (sparse plans only)."""
        self._require_interpolant("node_index")
        return self._extras["node_index"]

    def _require_interpolant(self, what: str) -> None:
        if not self.scheme.interpolates:
            which = [name for name, cls in METHOD_TYPES.items() if cls.interpolates]
            raise UnsupportedOperationError(
                f"{what} exists for the plans of an interpolating method "
                f"({', '.join(f'method={name!r}' for name in which)}) only, not {self.method!r}"
            )

    def interpolate(self, outputs: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
        """Sparse-grid interpolant of model outputs at parameter points (sparse plans only).

        Parameters
        ----------
        outputs : array_like, shape (N, ...)
            Model outputs at :attr:`samples` (all finite).
        points : array_like, shape (P, n)
            Parameter points inside the support box (parameter order of :attr:`names`).

        Returns
        -------
        ndarray, shape (P, ...)
        """
        self._require_interpolant("interpolate")
        values = np.asarray(outputs, dtype=float)
        if values.ndim == 0 or values.shape[0] != len(self):
            raise ModelOutputError(
                f"outputs must have leading axis N={len(self)} (one row per sample), got "
                f"shape {values.shape}"
            )
        if not np.all(np.isfinite(values)):
            raise ModelOutputError("outputs must be finite to build the sparse-grid interpolant")
        array = np.asarray(points, dtype=float)
        if array.ndim != 2 or array.shape[1] != len(self.names):
            raise InvalidPlanError(
                f"points must have shape (P, {len(self.names)}), got {array.shape}"
            )
        low, high = self.cut_lower[0], self.cut_upper[0]
        span = np.maximum(np.abs(low), np.abs(high))
        outside = (array < low - 1e-12 * span) | (array > high + 1e-12 * span)
        if outside.any():
            raise InvalidPlanError(
                "points must lie in the support box of the parameters (the interpolant does "
                f"not extrapolate); {int(outside.any(axis=1).sum())} point(s) are outside"
            )
        return self.sparse_grid.interpolate(self.to_unit_cube(array), values[self.node_index])

    # ------------------------------------------------------------------ queries
    def __len__(self) -> int:
        return len(self.samples)

    def __repr__(self) -> str:
        return (
            f"Plan(method={self.method!r}, parameters={list(self.names)}, "
            f"levels={len(self.levels)}, samples={len(self)})"
        )

    @property
    def nominal_index(self) -> int:
        """Row of ``samples`` holding the all-modal point."""
        return self._nominal_index

    @property
    def points_without_reuse(self) -> int:
        """Number of model runs the scheme needs if no point were reused across levels."""
        return self._points_without_reuse

    @property
    def level_usage(self) -> NDArray[np.bool_]:
        """(L, N) bool: sample i is one of the points evaluated at level j."""
        return self._level_usage

    def level_indices(self, level: int) -> NDArray[np.intp]:
        """Sample indices of the points of level ``level`` (in generation order, repeats kept)."""
        return self._level_index[level]

    @property
    def corner_index(self) -> NDArray[np.intp]:
        """(L, 2^n) sample index of the cut-box corners (methods with ``has_corners``:
        reduced, extended and grid)."""
        if not self.scheme.has_corners:
            which = [name for name, cls in METHOD_TYPES.items() if cls.has_corners]
            raise UnsupportedOperationError(
                f"corner bookkeeping exists for {', '.join(which)} plans, not {self.method!r}"
            )
        return self._corner_index

    def sample_columns(self) -> dict[str, NDArray[np.float64]]:
        """Samples as ``{name: (N,) array}``, the input format of a batched model."""
        return {name: self.samples[:, i].copy() for i, name in enumerate(self.names)}

    def check_failed(self, failed: ArrayLike | None) -> NDArray[np.bool_]:
        """Validate a failed-sample mask, returning an (N,) bool array (all False if None)."""
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
        """(L,) bool: levels whose nested bounds depend on a failed sample.

        Level j's bounds use the points of every level >= j.
        """
        mask = self.check_failed(failed)
        direct = np.any(self.level_usage & mask[None, :], axis=1)
        return np.logical_or.accumulate(direct[::-1])[::-1]

    # --------------------------------------------------------------- evaluation
    def evaluate(
        self,
        model: Callable[[dict[str, NDArray[np.float64]]], Mapping[str, Any]],
        chunk_size: int | None = None,
    ) -> dict[str, NDArray]:
        """Evaluate a batched model at all samples, ``chunk_size`` samples per call.

        Parameters
        ----------
        model : callable
            ``model({name: (B,) array}) -> {output: (B, ...) ndarray}``.
        chunk_size : int, optional
            Samples per call; all at once if None.

        Returns
        -------
        dict of str to ndarray
            Every output with leading axis N (in sample order).

        Raises
        ------
        ModelOutputError
            If the model returns something other than a mapping of numeric
            ndarrays with leading axis B, or outputs change between chunks.
        """
        return evaluate_table(model, self.names, self.samples, chunk_size)

    def retransform(
        self,
        outputs: ArrayLike | Mapping[str, ArrayLike],
        failed: ArrayLike | None = None,
        *,
        name: str = "output",
        check_monotonic: bool = True,
    ) -> FuzzyResult | dict[str, FuzzyResult]:
        """Fuzzy outputs from model outputs at the samples.

        Parameters
        ----------
        outputs : ndarray (N, ...) or mapping of str to ndarray (N, ...)
            Model outputs in sample order.
        failed : ndarray (N,) bool, optional
            Samples whose run failed; their values are ignored and the levels
            depending on them get NaN bounds (``complete`` False).
        name : str
            Output name used in warnings when ``outputs`` is a single array.
        check_monotonic : bool
            Warn (:class:`NonMonotonicWarning`) when a reduced/extended plan
            shows outputs outside a level's own range.

        Returns
        -------
        FuzzyResult or dict of str to FuzzyResult
            A dict for a mapping of outputs (the variant in rounds: of the outputs the
            rounds saw, checked against them; a single array is the one output of its
            shape, and ``check_monotonic`` has no effect).
        """
        if isinstance(outputs, Mapping):
            return {
                key: self._retransform_one(value, failed, key, True, check_monotonic)
                for key, value in outputs.items()
            }
        return self._retransform_one(outputs, failed, name, False, check_monotonic)

    def _retransform_one(
        self, values: ArrayLike, failed: ArrayLike | None, name: str, keyed: bool, check: bool
    ) -> FuzzyResult:
        """One output's result (``keyed``: ``name`` is the output's own key)."""
        return retransform(self, values, failed, name=name, check_monotonic=check)

    # ------------------------------------------------------------ serialising
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description: method, levels, parameters and the method's options."""
        return {
            "method": self.method,
            "levels": self.levels.tolist(),
            "parameters": {name: number.to_dict() for name, number in self.parameters.items()},
            **self.scheme.describe(),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, max_runs: int | None = None) -> Plan:
        """Rebuild a plan from :meth:`to_dict` output.

        ``max_runs`` as for :class:`Plan`; None (no limit) by default, since a
        described plan was accepted when it was made.
        """
        try:
            parameters = {
                name: FuzzyNumber.from_dict(value) for name, value in data["parameters"].items()
            }
            options = {
                key: value
                for key, value in data.items()
                if key not in ("method", "levels", "parameters")
            }
            scheme = method_named(data["method"], **options)
            return cls(parameters, method=scheme, levels=data["levels"], max_runs=max_runs)
        except (KeyError, AttributeError, TypeError) as error:
            raise InvalidPlanError(
                f"a plan description needs 'method', 'levels' and 'parameters', got {data!r}"
            ) from error

    def fingerprint(self) -> str:
        """Stable SHA-256 hex digest of the method, levels, parameters and sample table."""
        digest = hashlib.sha256()
        digest.update(json.dumps(self.to_dict(), sort_keys=True).encode())
        digest.update(np.ascontiguousarray(self.samples, dtype="<f8").tobytes())
        return digest.hexdigest()


#: a model's gradients ``{output: (B, *shape, n)}`` with respect to the fuzzy parameters
Gradients = Mapping[str, ArrayLike]


class RoundsPlan(Plan):
    """The plan of a method that runs in rounds (adaptive): points proposed until done.

    ``plan(parameters, method="adaptive", levels=m)`` returns one. Its points are not
    known in advance: each round's points follow from the outputs of the rounds before
    (the method's engine). A caller either drives the rounds (:meth:`next_batch` /
    :meth:`add`, what a study does with its executors and store) or lets
    :meth:`evaluate` do it with a model; afterwards :attr:`samples` holds every run in
    round order (row 0 is the modal point) and :meth:`retransform` gives the certified
    cuts. The arguments are those of :class:`Plan`; a method given by name takes
    ``max_runs`` as its run budget (the plan limit's default, and None, mean the
    method's default of 2,000).
    """

    def _start(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Start again from the first round (a study replays its stored rounds)."""
        self.engine = self.scheme.start(self.parameters, self.levels)
        self._outcome: Any = None

    @property
    def method_tolerance(self) -> float:
        """The certified error at which the rounds stop (cut-width scale)."""
        return self.scheme.method_tolerance  # type: ignore[attr-defined]

    @property
    def max_runs(self) -> int:
        """The run budget."""
        return self.scheme.max_runs  # type: ignore[attr-defined]

    # ------------------------------------------------------------------ rounds
    def next_batch(self) -> NDArray[np.float64]:
        """Points (B, n) of the next round; none once the rounds are done."""
        return self.engine.next_batch()

    def add(
        self,
        points: ArrayLike,
        outputs: Mapping[str, ArrayLike],
        *,
        gradients: Gradients | None = None,
    ) -> None:
        """The model's outputs ``{name: (B, ...)}`` at the points of :meth:`next_batch`, and
        optionally their gradients ``{name: (B, ..., n)}`` with respect to the fuzzy
        parameters (last axis in :attr:`names` order, the parameters' units; None: the
        value-only rounds)."""
        self._outcome = None
        self.engine.add(points, outputs, gradients)

    @property
    def done(self) -> bool:
        """No round is left (converged, or the budget is spent)."""
        return self.engine.done

    @property
    def confirming(self) -> bool:
        """The last round proposed confirms the method's result on the model, so that the
        rounds most likely end after it (False for a method without such a round)."""
        return bool(getattr(self.engine, "confirming", False))

    def outcome(self) -> Any:
        """Cuts, certified error, runs and rounds (once the rounds are done); the method
        warns if its budget or the model's noise stopped them above the tolerance."""
        if not self.engine.done:
            raise ModelOutputError(
                f"the {self.method} method has rounds left: call next_batch()/add() until "
                "next_batch() returns no point (or use evaluate(model))"
            )
        if self._outcome is None:
            self._outcome = self.engine.outcome()
            self.scheme.judge(self._outcome)  # type: ignore[attr-defined]
        return self._outcome

    def attrs(self) -> dict[str, Any]:
        """The result attributes of the outcome (the method's certified error and rounds)."""
        return self.scheme.attrs(self.outcome())  # type: ignore[attr-defined]

    # ----------------------------------------------------------------- samples
    @property  # type: ignore[override]
    def samples(self) -> NDArray[np.float64]:
        """(N, n) every run so far in round order; before the first round the modal point."""
        if self.engine.runs == 0:
            return np.array([[number.modal for number in self.parameters.values()]])
        return self.engine.samples

    def __repr__(self) -> str:
        return (
            f"RoundsPlan(method={self.method!r}, parameters={list(self.names)}, "
            f"levels={len(self.levels)}, runs={self.engine.runs}, "
            f"rounds={self.engine.rounds}, done={self.engine.done})"
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

    def level_indices(self, level: int) -> NDArray[np.intp]:
        """Every run (each enters the surrogate behind every level)."""
        return np.arange(len(self), dtype=np.intp)

    # --------------------------------------------------------------- evaluate
    def evaluate(
        self,
        model: Callable[[dict[str, NDArray[np.float64]]], Mapping[str, Any]],
        chunk_size: int | None = None,
    ) -> dict[str, NDArray]:
        """Run every round with ``model`` (``chunk_size`` samples per call) from the first,
        with the same checks of the model's outputs as :meth:`Plan.evaluate`.

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

    def _retransform_one(
        self, values: ArrayLike, failed: ArrayLike | None, name: str, keyed: bool, check: bool
    ) -> FuzzyResult:
        """The certified cuts of one output the rounds saw.

        Raises
        ------
        ModelOutputError
            Outputs that are not those of the rounds, or rounds not finished.
        IncompleteResultError
            Failed runs (the surrogate needs every run).
        """
        mask = self.check_failed(failed)
        if mask.any():
            raise IncompleteResultError(
                f"{int(mask.sum())} of {len(self)} runs of the {self.method} method failed; "
                "its surrogate needs every run, so no level can be bounded"
            )
        outcome = self.outcome()
        if keyed:
            return self._result(name, values, outcome)
        matches = [
            key
            for key, (_, shape) in self.engine.layout.items()
            if (len(self), *shape) == np.shape(values)
        ]
        if len(matches) != 1:
            raise ModelOutputError(
                f"output {name!r}: pass the outputs as a dict {{name: array}}; the rounds saw "
                f"{sorted(self.engine.layout)}"
            )
        return self._result(matches[0], values, outcome)

    def _result(self, key: str, values: ArrayLike, outcome: Any) -> FuzzyResult:
        if key not in outcome.lower:
            raise ModelOutputError(
                f"output {key!r} was not among the outputs the rounds saw: {sorted(outcome.lower)}"
            )
        array = np.asarray(values, dtype=float)
        expected = self.engine.output(key)
        if array.shape != expected.shape or not np.array_equal(array, expected):
            raise ModelOutputError(
                f"output {key!r} differs from the outputs the {self.method} rounds were given "
                "(its bounds come from those runs)"
            )
        return FuzzyResult(
            self.levels,
            outcome.lower[key],
            outcome.upper[key],
            nominal=outcome.nominal[key],
            method=self.method,
            _plan=self,
            _sums=(outcome.pair_sum[key], np.zeros(len(self.levels), dtype=bool)),
        )

    def fingerprint(self) -> str:
        """SHA-256 of :meth:`to_dict` (the runs follow from it and the model)."""
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()


#: build a sampling plan: ``plan(...)`` is ``Plan(...)``, one signature documented on :class:`Plan`
plan = Plan
