"""The sparse method: a Smolyak sparse grid over the support box, interpolated.

The nodes of a Smolyak sparse grid on Clenshaw-Curtis points
(:mod:`fuzzymbs.fuzzy.sparse_grid`, level ``sparse_level``) mapped to the
support box (the mu = 0 cut); retransformation interpolates the outputs and
searches each cut box for the interpolant's min/max (Klimke & Wohlmuth, Fuzzy
Sets and Systems 154 (2005) 432). Every sample serves every level; the modal
point is sample 0 and a candidate of every level's search.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.grids import unique_rows
from fuzzymbs.fuzzy.methods.base import CountRequest, Method, NumberShape, Sampling, option
from fuzzymbs.fuzzy.methods.base import to_parameter_space as mapped
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, node_count, nodes_1d

__all__ = [
    "DEFAULT_SEARCH_POINTS",
    "DEFAULT_SPARSE_LEVEL",
    "MAX_SEARCH_POINTS",
    "Sparse",
    "check_sparse_search",
]

#: default ``sparse_level`` (Smolyak's q = n + 3: exact for polynomials of total degree 3)
DEFAULT_SPARSE_LEVEL = 3
#: default number of search points per cut box of a sparse plan (at least 3^n are used)
DEFAULT_SEARCH_POINTS = 20_000
#: the most search points per cut box a sparse plan's retransformation evaluates: 3^15, the
#: tensor grid of 15 parameters (1.7 GB of points per cut box before the interpolant runs)
MAX_SEARCH_POINTS = 3**15
#: the modal point's search over the 1-D sparse nodes stops at this sparse level (2^20 nodes)
_MODAL_SEARCH_LEVEL = 20


@dataclass(frozen=True)
class Sparse(Method):
    """The sparse-grid method.

    Parameters
    ----------
    sparse_level : int
        Smolyak level ``q - n >= 1`` (the interpolant reproduces polynomials of total
        degree <= sparse_level).
    search_points : int, optional
        Points of the tensor search grid per cut box, ``k = floor(search_points^(1/n))``
        per parameter (default ``max(20000, 3^n)``; at least ``3^n``).
    """

    name = "sparse"
    summary = "a Smolyak sparse grid on the support, interpolated; smooth models, many parameters"
    supports_streaming = False
    interpolates = True

    sparse_level: int = option(
        DEFAULT_SPARSE_LEVEL,
        "Smolyak level q - n of the sparse grid",
        must=f"an int >= 1 (Smolyak level q - n; {DEFAULT_SPARSE_LEVEL} by default)",
        minimum=1,
    )
    search_points: int | None = option(
        None,
        "search points per cut box on the interpolant (default max(20000, 3^n))",
        must="an int >= 3^n (at least 3 points per parameter in each cut box)",
        minimum=1,
    )

    def checked(self, names: tuple[str, ...]) -> Sparse:
        """``search_points`` at least ``3^n`` (default ``max(20000, 3^n)``)."""
        minimum = 3 ** len(names)
        if self.search_points is None:
            return replace(self, search_points=max(DEFAULT_SEARCH_POINTS, minimum))
        if self.search_points < minimum:
            raise InvalidPlanError(
                f"search_points must be an int >= 3^n = {minimum} for n = {len(names)} "
                f"parameters (at least 3 points per parameter in each cut box), got "
                f"{self.search_points!r}"
            )
        return self

    def describe(self) -> dict[str, int | None]:
        return {"sparse_level": self.sparse_level, "search_points": self.search_points}

    def check_bounds(self, count_parameters: int) -> None:
        """The search of the cut boxes needs ``3^n`` points: at most 15 parameters."""
        check_sparse_search(count_parameters)

    # ------------------------------------------------------------------ count
    def least_runs(self) -> int:
        """Beyond level 60: the grid's 1-D axis of ``2^level + 1`` nodes (no exact count)."""
        return 2**self.sparse_level + 1 if self.sparse_level > 60 else 0

    def count(self, request: CountRequest) -> tuple[int, bool]:
        """Smolyak nodes mapped to the support box, plus the modal point unless it is one.

        A crisp parameter whose support maps every 1-D node onto its value drops
        out of the grid (the nodes project onto a grid of the same level in the
        other parameters). The modal point is a node when every parameter's modal
        value is a mapped 1-D node of level ``l_i`` and ``sum (l_i - 1) <= level``.
        Vectorised over the parameters: linear in n. Not exact (an upper bound)
        where a support so narrow that two of its mapped 1-D nodes round to the
        same float (but not all of them) merges nodes.
        """
        return _sparse_count(request.shapes, self.sparse_level)

    # ------------------------------------------------------------------ build
    def build(
        self, parameters: dict[str, FuzzyNumber], cut_lower: NDArray, cut_upper: NDArray
    ) -> Sampling:
        """Modal point first, then the sparse-grid nodes mapped to the support box.

        The same samples as ``unique_rows`` of the modal point and the mapped nodes
        (first appearance, exact float equality), computed from the nodes' entries
        off the midpoint: a node differs from the centre of the box in at most
        ``sparse_level`` coordinates, so building costs O(N level) plus filling the
        (N, n) table, not a sort of N rows of n numbers.
        """
        count_levels, count_parameters = cut_lower.shape
        grid = SparseGrid(count_parameters, self.sparse_level)
        dims, positions = grid.entries
        unit, _ = nodes_1d(self.sparse_level)  # value of every position 0..denominator
        # table[i, p]: parameter i at position p, by the same arithmetic as the plan's mapping
        table = mapped(
            np.broadcast_to(unit, (count_parameters, len(unit))).T, cut_lower[0], cut_upper[0]
        ).T
        canonical = _first_equal(table)  # positions mapping onto the same value merge
        middle = grid.midpoint_position
        used = dims < count_parameters
        safe_dims = np.where(used, dims, 0)
        node_canonical = np.where(used, canonical[safe_dims, positions], -1)
        off_centre = used & (node_canonical != canonical[safe_dims, middle])
        node_keys = _entry_keys(
            np.where(off_centre, dims, count_parameters), node_canonical, count_parameters
        )
        modal = np.array([number.modal for number in parameters.values()])
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
        samples.setflags(write=False)
        node_index = inverse[1:]
        node_index.setflags(write=False)
        everything = np.arange(count, dtype=np.intp)
        everything.setflags(write=False)
        # the interpolant behind every level's bounds needs every sample
        usage = np.ones((count_levels, count), dtype=bool)
        usage.setflags(write=False)
        return Sampling(
            samples,
            [everything] * count_levels,
            int(inverse[0]),
            count,
            usage,
            extras={"sparse_grid": grid, "node_index": node_index},
        )


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


def _sparse_count(shapes: list[NumberShape], level: int) -> tuple[int, bool]:
    """``(runs, exact)`` of a sparse plan (see :meth:`Sparse.count`)."""
    searched = level <= _MODAL_SEARCH_LEVEL
    if searched:
        unit, first_level = nodes_1d(level)
    else:  # only the midpoint is looked at: an upper bound if the modal point is another node
        unit, first_level = np.array([0.5]), np.array([1])
    table = np.array([(s.support_lower, s.support_upper, s.modal, s.crisp) for s in shapes])
    low, high, modal, crisp = table[:, 0:1], table[:, 1:2], table[:, 2:3], table[:, 3] > 0
    # the same arithmetic as the builder's mapping
    mapped_nodes = low * (1.0 - unit) + high * unit
    collapsed = (
        crisp & np.all(mapped_nodes == modal, axis=1) if searched else np.zeros(len(shapes), bool)
    )
    dimension = int(np.count_nonzero(~collapsed))
    hits = mapped_nodes == modal
    has_hit = hits.any(axis=1)
    first_hit = np.where(hits, first_level[None, :], np.iinfo(np.int64).max).min(axis=1)
    kept = ~collapsed
    modal_is_node = bool(np.all(has_hit[kept])) and int((first_hit[kept] - 1).sum()) <= level
    exact = True
    if searched and len(unit) > 1:
        ordered = np.sort(mapped_nodes[kept], axis=1)
        exact = bool(np.all(ordered[:, 1:] != ordered[:, :-1]))
    return node_count(dimension, level) + (0 if modal_is_node else 1), exact


def check_sparse_search(count_parameters: int) -> None:
    """Refuse a sparse retransformation whose search grid per cut box cannot be evaluated.

    The search needs at least 3 points per parameter in every cut box, ``3^n``
    in all; beyond :data:`MAX_SEARCH_POINTS` (n > 15) it cannot run, so a study
    refuses such a plan before evaluating any sample, and a plan's
    retransformation refuses it instead of running out of memory. The plan itself
    (its samples, its interpolant) has no such limit.

    Raises
    ------
    InvalidPlanError
        ``3^n`` above :data:`MAX_SEARCH_POINTS`.
    """
    if count_parameters <= 15:  # 3^15 = MAX_SEARCH_POINTS; no huge power for large n
        return
    digits = int(count_parameters * math.log10(3.0))
    raise InvalidPlanError(
        f"the sparse method finds every cut's bounds by searching its interpolant on a "
        f"tensor grid of at least 3 points per parameter: 3^{count_parameters} (about "
        f"1e{digits}) points per cut box for {count_parameters} fuzzy parameters, more than "
        f"the {MAX_SEARCH_POINTS:,} (3^15) it can evaluate: the sparse method serves at "
        f"most 15 fuzzy parameters"
    )
