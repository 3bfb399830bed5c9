"""Transformation method (Hanss): sampling plans over the alpha-cuts of fuzzy parameters.

A :class:`Plan` holds the unique sample points a model must be evaluated at and
the bookkeeping that says which points belong to which membership level (and,
for the reduced and extended schemes, which corner runs pair up in one
parameter). Retransformation and influence measures use that bookkeeping only.

Schemes (``mu_j``, j = 0..m, with cuts ``[a_i^(j), b_i^(j)]`` of parameter i):

``"general"``
    Per parameter the points ``P_m`` = the core bounds (one point for a
    single-point core) and, for j < m, ``P_j = {a^(j)} + midpoints of
    consecutive points of P_(j+1) + {b^(j)}`` (Hanss 2002: M_j = m + 1 - j
    points); all combinations at every level.
``"reduced"``
    The 2^n corners of the cut box at every level (the core box at level m,
    one point for single-point cores). Exact for models monotonic in every
    parameter.
``"extended"``
    The reduced corners plus, for the parameters named ``nonmonotonic``, the
    general-method points ``P_j``: at level j the full factorial of ``P_j``
    for those parameters and ``{a^(j), b^(j)}`` for all others.
``"grid"``
    At level j the full factorial of all cut bounds of levels j..m (the full
    alpha-bound grid; exact on the grid for any model).
``"sparse"``
    The nodes of a Smolyak sparse grid on Clenshaw-Curtis points
    (:mod:`fuzzymbs.fuzzy.sparse_grid`, level ``sparse_level``) mapped to the
    support box (the mu = 0 cut); retransformation interpolates the outputs
    and searches each cut box for the interpolant's min/max (Klimke &
    Wohlmuth, Fuzzy Sets and Systems 154 (2005) 432). Every sample serves
    every level.

Every plan also contains the all-modal point (sample 0), evaluated at level m
(for ``"sparse"``: a candidate of every level's search).
Identical points are evaluated once: points are built from the same cut values
and merged by exact floating-point equality.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidPlanError, ModelOutputError, UnsupportedOperationError
from fuzzymbs.fuzzy.grids import cartesian, unique_rows
from fuzzymbs.fuzzy.level_values import level_value_sets
from fuzzymbs.fuzzy.model_calls import evaluate_table
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import METHODS, checked_parameters, make_levels, sparse_options
from fuzzymbs.fuzzy.plan_size import DEFAULT_MAX_RUNS, check_run_limit, run_count
from fuzzymbs.fuzzy.retransform import FuzzyResult, NonMonotonicWarning, retransform
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, nodes_1d

__all__ = [
    "ALL_METHODS",
    "DEFAULT_MAX_RUNS",
    "METHODS",
    "NonMonotonicWarning",
    "Plan",
    "make_levels",
    "plan",
    "run_count",
]


#: every method :func:`plan` accepts: the fixed schemes and "adaptive" (an AdaptivePlan)
ALL_METHODS: tuple[str, ...] = (*METHODS, "adaptive")


def _first_equal(table: NDArray[np.float64]) -> NDArray[np.intp]:
    """Per row, the first column holding the same value (exact float equality) as each column."""
    order = np.argsort(table, axis=1, kind="stable")
    ordered = np.take_along_axis(table, order, axis=1)
    starts = np.zeros(table.shape, dtype=np.intp)
    columns = np.arange(table.shape[1])
    starts[:, 1:] = np.where(ordered[:, 1:] != ordered[:, :-1], columns[1:], 0)
    # stable sort: the first column of a run of equal values is the smallest one
    first = np.take_along_axis(order, np.maximum.accumulate(starts, axis=1), axis=1)
    result = np.empty_like(order)
    np.put_along_axis(result, order, first, axis=1)
    return result


def _entry_keys(
    dims: NDArray[np.intp], values: NDArray[np.intp], count_parameters: int
) -> NDArray[np.float64]:
    """Rows (dim, value) of the entries kept (dim < n), by increasing dim, padded with (n, -1)."""
    order = np.argsort(dims, axis=1, kind="stable")
    dims = np.take_along_axis(dims, order, axis=1)
    values = np.where(dims < count_parameters, np.take_along_axis(values, order, axis=1), -1)
    keys = np.empty((len(dims), 2 * dims.shape[1]))
    keys[:, 0::2] = dims
    keys[:, 1::2] = values
    return keys


def _modal_key(
    table: NDArray[np.float64],
    canonical: NDArray[np.intp],
    middle: int,
    modal: NDArray[np.float64],
    width: int,
) -> NDArray[np.float64]:
    """The modal point's entry key if it may be a node (every value a mapped node), else -2s."""
    count_parameters = len(modal)
    hits = table == modal[:, None]
    if not hits.any(axis=1).all():
        return np.full(width, -2.0)
    position = canonical[np.arange(count_parameters), hits.argmax(axis=1)]
    off = np.nonzero(position != canonical[:, middle])[0]
    if 2 * len(off) > width:  # more coordinates off the centre than any node has
        return np.full(width, -2.0)
    dims = np.full((1, width // 2), count_parameters, dtype=np.intp)
    values = np.full((1, width // 2), -1, dtype=np.intp)
    dims[0, : len(off)] = off
    values[0, : len(off)] = position[off]
    return _entry_keys(dims, values, count_parameters)[0]


class Plan:
    """Sample points of a transformation-method scheme and their level bookkeeping.

    ``plan(...)`` is the same as ``Plan(...)``. Attributes are read-only by convention.

    Parameters
    ----------
    parameters : mapping of str to FuzzyNumber
        Fuzzy parameters by name (their order fixes the sample columns).
    method : {"general", "reduced", "extended", "grid", "sparse"}
        Sampling scheme (see the module docstring and docs/theory.md).
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
        ``max(20000, 3^n)``; at least ``3^n``).
    max_runs : int or None, optional
        Refuse the plan, before anything is built, if it needs more model runs
        than this (:func:`run_count`) or its level bookkeeping (levels x runs)
        more than 10 x this; default :data:`DEFAULT_MAX_RUNS` (1,000,000), None:
        no limit. See :func:`~fuzzymbs.fuzzy.plan_size.check_run_limit`.

    Attributes
    ----------
    parameters : dict of str to FuzzyNumber
        The fuzzy parameters, in insertion order.
    names : tuple of str
        Parameter names (column order of ``samples``).
    levels : ndarray, shape (L,)
        Membership levels mu_0 = 0 ... mu_m = 1.
    method : str
        One of :data:`METHODS`.
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
        Unknown method, bad levels, unknown or misplaced nonmonotonic names,
        sparse options that are invalid or given with another method,
        parameters that are not fuzzy numbers.
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

    def __new__(cls, parameters: Any = None, method: str = "reduced", *args: Any, **kwargs: Any):
        """``method="adaptive"`` gives an :class:`~fuzzymbs.fuzzy.adaptive_plan.AdaptivePlan`
        (its points come in rounds); every other method a :class:`Plan`."""
        if method == "adaptive":
            from fuzzymbs.fuzzy.adaptive_plan import adaptive_plan

            return adaptive_plan(parameters, *args, **kwargs)
        return super().__new__(cls)

    def __init__(
        self,
        parameters: Mapping[str, FuzzyNumber],
        method: str = "reduced",
        levels: int | ArrayLike = 4,
        nonmonotonic: Iterable[str] | None = None,
        *,
        sparse_level: int | None = None,
        search_points: int | None = None,
        max_runs: int | None = DEFAULT_MAX_RUNS,
    ) -> None:
        if not isinstance(method, str) or method not in METHODS:
            raise InvalidPlanError(f"unknown method {method!r}; valid methods: {list(ALL_METHODS)}")
        self.parameters: dict[str, FuzzyNumber] = checked_parameters(parameters)
        self.names: tuple[str, ...] = tuple(self.parameters)
        self.method = method
        if nonmonotonic is None:
            nonmonotonic = ()
        if isinstance(nonmonotonic, str):
            nonmonotonic = (nonmonotonic,)
        nonmonotonic = tuple(nonmonotonic)
        unknown = [name for name in nonmonotonic if name not in self.parameters]
        if unknown:
            raise InvalidPlanError(
                f"nonmonotonic names unknown parameters {unknown}; parameters: {list(self.names)}"
            )
        if nonmonotonic and method != "extended":
            raise InvalidPlanError(
                f"nonmonotonic={list(nonmonotonic)} is only used by method='extended', "
                f"not {method!r}"
            )
        # keep the parameter order, drop repeats
        self.nonmonotonic: tuple[str, ...] = tuple(n for n in self.names if n in nonmonotonic)
        self.sparse_level, self.search_points = sparse_options(
            method, len(self.names), sparse_level, search_points
        )
        # the size first, from closed forms: nothing below may allocate a plan too large to run
        check_run_limit(
            self.parameters,
            method,
            levels,
            self.nonmonotonic,
            self.sparse_level,
            max_runs=max_runs,
        )
        self.levels = make_levels(levels)

        cuts = np.stack([number.cuts(self.levels) for number in self.parameters.values()], axis=1)
        self.cut_lower: NDArray[np.float64] = cuts[:, :, 0]  # (L, n)
        self.cut_upper: NDArray[np.float64] = cuts[:, :, 1]
        self._build()

    # ----------------------------------------------------------------- building
    def _level_values(self) -> list[list[NDArray[np.float64]]]:
        """values[j][i]: the coordinates parameter i takes at level j (all combined)."""
        interior = [name in self.nonmonotonic for name in self.names]
        return level_value_sets(self.cut_lower, self.cut_upper, self.method, interior)

    def _build(self) -> None:
        if self.method == "sparse":
            self._build_sparse()
            return
        count_levels = len(self.levels)
        modal_point = np.array([[number.modal for number in self.parameters.values()]])
        level_points = [cartesian(values) for values in self._level_values()]
        # nominal point first, then levels from the core down, so that samples
        # are ordered by first use from the top level
        blocks = [modal_point, *level_points[::-1]]
        sizes = [len(block) for block in blocks]
        unique, inverse = unique_rows(np.concatenate(blocks, axis=0))
        self.samples: NDArray[np.float64] = unique
        self.samples.setflags(write=False)
        offsets = np.cumsum([0, *sizes])
        nominal = int(inverse[0])
        per_level_from_top = [inverse[offsets[k + 1] : offsets[k + 2]] for k in range(count_levels)]
        self._level_index: list[NDArray[np.intp]] = per_level_from_top[::-1]
        # the nominal point lies in the core box: it belongs to the top level
        self._level_index[-1] = np.concatenate((self._level_index[-1], [nominal]))
        self._nominal_index = nominal
        # runs if every level were evaluated on its own (repeats inside a level merged)
        self._points_without_reuse = sum(len(unique_rows(points)[0]) for points in level_points)
        usage = np.zeros((count_levels, len(unique)), dtype=bool)
        for j, index in enumerate(self._level_index):
            usage[j, index] = True
        usage.setflags(write=False)
        self._level_usage = usage
        if self.method in ("reduced", "extended", "grid"):
            # the grid holds every level's cut-box corners too: its influence measures
            self._corner_index = self._corners()

    def _build_sparse(self) -> None:
        """Modal point first, then the sparse-grid nodes mapped to the support box.

        The same samples as ``unique_rows`` of the modal point and the mapped nodes
        (first appearance, exact float equality), computed from the nodes' entries
        off the midpoint: a node differs from the centre of the box in at most
        ``sparse_level`` coordinates, so building costs O(N level) plus filling the
        (N, n) table, not a sort of N rows of n numbers.
        """
        assert self.sparse_level is not None  # set by sparse_options for "sparse"
        count_levels, count_parameters = self.cut_lower.shape
        self._sparse_grid = SparseGrid(count_parameters, self.sparse_level)
        grid = self._sparse_grid
        dims, positions = grid.entries
        unit, _ = nodes_1d(self.sparse_level)  # value of every position 0..denominator
        # table[i, p]: parameter i at position p, by the same arithmetic as to_parameter_space
        table = self.to_parameter_space(np.broadcast_to(unit, (count_parameters, len(unit))).T).T
        canonical = _first_equal(table)  # positions mapping onto the same value merge
        middle = grid.midpoint_position
        used = dims < count_parameters
        safe_dims = np.where(used, dims, 0)
        node_canonical = np.where(used, canonical[safe_dims, positions], -1)
        off_centre = used & (node_canonical != canonical[safe_dims, middle])
        node_keys = _entry_keys(
            np.where(off_centre, dims, count_parameters), node_canonical, count_parameters
        )
        modal = np.array([number.modal for number in self.parameters.values()])
        modal_key = _modal_key(table, canonical, middle, modal, node_keys.shape[1])
        unique_keys, inverse = unique_rows(np.concatenate((modal_key[None, :], node_keys)))
        count = len(unique_keys)
        # as unique_rows(points) writes the rows: a merged row holds its last member's values
        last = np.full(count, -1, dtype=np.intp)
        np.maximum.at(last, inverse, np.arange(len(inverse)))
        samples = np.empty((count, count_parameters))
        samples[:] = table[:, middle]
        if last[inverse[0]] == 0:  # the modal point is a sample of its own
            samples[inverse[0]] = modal
        node_rows = np.nonzero(last > 0)[0]
        members = last[node_rows] - 1
        member_used = used[members]
        rows = np.broadcast_to(node_rows[:, None], member_used.shape)[member_used]
        columns = dims[members][member_used]
        samples[rows, columns] = table[columns, positions[members][member_used]]
        self.samples = samples
        self.samples.setflags(write=False)
        self._nominal_index = int(inverse[0])
        self._node_index: NDArray[np.intp] = inverse[1:]
        self._node_index.setflags(write=False)
        everything = np.arange(count, dtype=np.intp)
        everything.setflags(write=False)
        self._level_index = [everything] * count_levels
        self._points_without_reuse = count
        # the interpolant behind every level's bounds needs every sample
        usage = np.ones((count_levels, count), dtype=bool)
        usage.setflags(write=False)
        self._level_usage = usage

    def to_parameter_space(self, unit_points: ArrayLike) -> NDArray[np.float64]:
        """Map points of the unit cube [0, 1]^n to the support box (the mu = 0 cut)."""
        unit = np.asarray(unit_points, dtype=float)
        low, high = self.cut_lower[0], self.cut_upper[0]
        # this form maps 0 and 1 exactly onto the support bounds
        return low * (1.0 - unit) + high * unit

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
        self._require_sparse("sparse_grid")
        return self._sparse_grid

    @property
    def node_index(self) -> NDArray[np.intp]:
        """(N_nodes,) sample index of every sparse-grid node (sparse plans only)."""
        self._require_sparse("node_index")
        return self._node_index

    def _require_sparse(self, what: str) -> None:
        if self.method != "sparse":
            raise UnsupportedOperationError(
                f"{what} exists for method='sparse' plans only, not {self.method!r}"
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
        self._require_sparse("interpolate")
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
        return self._sparse_grid.interpolate(self.to_unit_cube(array), values[self._node_index])

    def _corners(self) -> NDArray[np.intp]:
        """Sample index of every corner: (L, 2^n), corner s uses b_i where bit n-1-i of s is set.

        Corner s and s + 2^(n-1-i) differ only in parameter i (a_i then b_i).
        """
        count_levels, count_parameters = self.cut_lower.shape
        bits = (
            np.arange(2**count_parameters)[:, None] >> np.arange(count_parameters - 1, -1, -1)
        ) & 1
        corner_index = np.empty((count_levels, 2**count_parameters), dtype=np.intp)
        for j in range(count_levels):
            corners = np.where(bits == 1, self.cut_upper[j], self.cut_lower[j])
            corner_index[j] = self._locate(corners)
        return corner_index

    def _locate(self, points: NDArray[np.float64]) -> NDArray[np.intp]:
        """Sample index of each row of ``points`` (which must be samples, exactly)."""
        combined = np.concatenate((self.samples, points), axis=0)
        unique, inverse = unique_rows(combined)
        if len(unique) != len(self.samples):  # pragma: no cover - internal consistency
            raise RuntimeError("corner point missing from the sample table")
        return inverse[len(self.samples) :]

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
        """(L, 2^n) sample index of the cut-box corners (reduced, extended and grid plans)."""
        if self.method not in ("reduced", "extended", "grid"):
            raise UnsupportedOperationError(
                f"corner bookkeeping exists for reduced, extended and grid plans, "
                f"not {self.method!r}"
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
        direct = np.any(self._level_usage & mask[None, :], axis=1)
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
        """
        if isinstance(outputs, Mapping):
            return {
                key: retransform(self, value, failed, name=key, check_monotonic=check_monotonic)
                for key, value in outputs.items()
            }
        return retransform(self, outputs, failed, name=name, check_monotonic=check_monotonic)

    # ------------------------------------------------------------ serialising
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description: method, levels, parameters, nonmonotonic, sparse options."""
        description: dict[str, Any] = {
            "method": self.method,
            "levels": self.levels.tolist(),
            "parameters": {name: number.to_dict() for name, number in self.parameters.items()},
        }
        if self.nonmonotonic:
            description["nonmonotonic"] = list(self.nonmonotonic)
        if self.method == "sparse":
            description["sparse_level"] = self.sparse_level
            description["search_points"] = self.search_points
        return description

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
            return cls(
                parameters,
                method=data["method"],
                levels=data["levels"],
                nonmonotonic=data.get("nonmonotonic"),
                sparse_level=data.get("sparse_level"),
                search_points=data.get("search_points"),
                max_runs=max_runs,
            )
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


#: build a sampling plan: ``plan(...)`` is ``Plan(...)``, one signature documented on :class:`Plan`
plan = Plan
