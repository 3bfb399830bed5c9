"""Smolyak sparse-grid interpolation on nested Clenshaw-Curtis nodes in [0, 1]^n.

The sparse-grid variant of the transformation method (Klimke & Wohlmuth,
Fuzzy Sets and Systems 154 (2005) 432; Klimke's spinterp) replaces the
exhaustive sampling of every alpha-cut box by one interpolant of the model on
the support box, whose minimum and maximum are then searched in each box.

Construction (Barthelmann, Novak & Ritter, Adv. Comput. Math. 12 (2000)
273-288, eqs. (2)-(4) and Lemma 1; Klimke & Wohlmuth 2005, section 3):

* 1-D nodes of level ``i >= 1``: ``m_1 = 1`` node (the midpoint 0.5) and
  ``m_i = 2^(i-1) + 1`` Clenshaw-Curtis nodes ``x_k = (1 - cos(pi k/(m_i-1)))/2``,
  ``k = 0..m_i-1``, otherwise. The sets are nested.
* ``U^i``: polynomial interpolation of degree ``m_i - 1`` on those nodes,
  evaluated in barycentric form with the Chebyshev-point weights
  ``w_k = (-1)^k``, halved at both ends (Berrut & Trefethen, SIAM Review 46
  (2004) 501, eq. (5.4)).
* Smolyak's formula in the combination form, with ``q = n + level``::

      A(q, n) = sum over i in N^n, q-n+1 <= |i| <= q, of
                (-1)^(q-|i|) binom(n-1, q-|i|) (U^(i_1) x ... x U^(i_n))

  and the nodes ``H(q, n)`` = union of the tensor grids ``X^(i_1) x ... x X^(i_n)``
  over the same multi-indices. ``A(q, n)`` interpolates at ``H(q, n)``
  (nested nodes, Barthelmann et al. Prop. 6) and reproduces every polynomial of
  total degree <= ``level`` (each monomial of total degree <= level lies in one
  tensor space with ``|i| <= q``: a degree-1 factor needs ``i_j = 2``).

``level`` below is ``q - n`` (spinterp's level; level 0 is the single midpoint).
Node counts for n = 2: 1, 5, 13, 29, 65; n = 3: 1, 7, 25, 69, 177 for levels
0..4 (tests compare them with a brute-force union of tensor grids).

Node count in closed form (:func:`node_count`, derived): 1-D level ``i`` adds
1, 2, 2, 4, 8, ..., ``2^(i-2)`` new nodes for i = 1, 2, 3, 4, ...; with the
increment ``r = i - 1`` their generating function is
``1 + 2z + 2z^2 + 4z^3 + ... = (1 - 2z^2) / (1 - 2z)``. Every node of ``H(q, n)``
is new in exactly one tensor product of increments with ``sum r_j <= level``,
so ``|H(q, n)| = [z^level] (1 - 2z^2)^n / ((1 - 2z)^n (1 - z))``.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from functools import cached_property
from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError

__all__ = ["SparseGrid", "node_count", "nodes_1d", "sparse_grid"]

#: memory bound of one block of interpolation weights / interpolated values (float64 elements)
_BLOCK_ELEMENTS = 2_000_000


def _check_int(value: object, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InvalidParameterError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def _node_count_1d(level: int) -> int:
    """m_i: 1 for level 1, 2^(i-1) + 1 above."""
    return 1 if level == 1 else 2 ** (level - 1) + 1


def _positions_1d(level: int, denominator: int) -> NDArray[np.int64]:
    """Node positions p of 1-D level ``level`` on the common scale 0..denominator.

    The node is ``(1 - cos(pi p / denominator)) / 2``; using one integer scale
    for every level makes shared nodes bit-identical.
    """
    if level == 1:
        return np.array([denominator // 2], dtype=np.int64)
    step = denominator // 2 ** (level - 1)
    return np.arange(0, denominator + 1, step, dtype=np.int64)


def _new_positions_1d(level: int, denominator: int) -> NDArray[np.int64]:
    """Positions that 1-D level ``level >= 2`` adds: the ends, then odd multiples of its step."""
    if level == 2:
        return np.array([0, denominator], dtype=np.int64)
    step = denominator // 2 ** (level - 1)
    return np.arange(step, denominator, 2 * step, dtype=np.int64)


def _level_patterns(level: int, width: int) -> Iterator[tuple[int, ...]]:
    """Tuples of 1-D levels >= 2, at most ``width`` long, with ``sum(l - 1) <= level``."""

    def extend(prefix: tuple[int, ...], budget: int) -> Iterator[tuple[int, ...]]:
        if prefix:
            yield prefix
        if len(prefix) == width:
            return
        for extra in range(1, budget + 1):
            yield from extend((*prefix, extra + 1), budget - extra)

    yield from extend((), level)


def _combinations(n: int, width: int) -> NDArray[np.intp]:
    """All increasing ``width``-tuples of ``range(n)`` as rows (lexicographic), vectorised."""
    combos = np.arange(n, dtype=np.intp)[:, None]
    for _ in range(width - 1):
        # append every larger value to each row
        counts = n - 1 - combos[:, -1]
        rows = np.repeat(np.arange(len(combos)), counts)
        starts = np.cumsum(counts) - counts
        offsets = np.arange(len(rows)) - np.repeat(starts, counts)
        combos = np.column_stack((combos[rows], combos[rows, -1] + 1 + offsets))
    return combos


def _cartesian_int(axes: Sequence[NDArray[np.int64]]) -> NDArray[np.int64]:
    """All combinations of integer axes as rows, the first axis slowest."""
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([grid.reshape(-1) for grid in grids], axis=1)


def _node_values(positions: NDArray[np.int64], denominator: int) -> NDArray[np.float64]:
    """CC nodes from positions: 0.5 - 0.5 sin(pi (D - 2p) / (2D)).

    Written with the sine so that the midpoint is exactly 0.5 and the ends
    exactly 0 and 1 (cos(pi/2) is 6e-17 in floating point).
    """
    return 0.5 - 0.5 * np.sin(np.pi * (denominator - 2 * positions) / (2 * denominator))


def _barycentric_weights(count: int) -> NDArray[np.float64]:
    """Barycentric weights of Chebyshev points of the second kind (Berrut & Trefethen eq. 5.4).

    Our nodes run from 0 to 1 (cosine from +1 to -1), which flips the sign of
    every weight; a common factor cancels in the barycentric formula.
    """
    weights = (-1.0) ** np.arange(count)
    weights[0] *= 0.5
    weights[-1] *= 0.5
    return weights


def _lagrange_basis(x: NDArray[np.float64], nodes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lagrange basis (P, m) of the nodes at the points x (P,), barycentric form."""
    if len(nodes) == 1:
        return np.ones((len(x), 1))
    weights = _barycentric_weights(len(nodes))
    difference = x[:, None] - nodes[None, :]
    exact = difference == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = weights / difference
        basis = terms / terms.sum(axis=1, keepdims=True)
    hit = exact.any(axis=1)
    if hit.any():
        basis[hit] = exact[hit].astype(float)
    return basis


class SparseGrid:
    """Smolyak sparse grid and interpolant on nested Clenshaw-Curtis nodes in [0, 1]^n.

    Parameters
    ----------
    dimension : int
        Number of variables n >= 1.
    level : int
        Sparse-grid level ``k = q - n >= 0`` (the interpolant reproduces
        polynomials of total degree <= k).

    Attributes
    ----------
    dimension, level : int
    nodes : ndarray, shape (N, n)
        Unique nodes, ordered by the level of the tensor grid that first holds
        them (the midpoint first), then lexicographically.
    terms : list of (tuple of int, float)
        Multi-indices ``i`` of the combination technique and their coefficients
        ``(-1)^(q-|i|) binom(n-1, q-|i|)``.

    Examples
    --------
    >>> grid = SparseGrid(2, 2)
    >>> len(grid.nodes)
    13
    >>> values = grid.nodes[:, 0] ** 2 * grid.nodes[:, 1]
    >>> float(grid.interpolate([[0.5, 0.5]], values)[0])   # a node: the data itself
    0.125
    """

    def __init__(self, dimension: int, level: int) -> None:
        self.dimension = _check_int(dimension, "dimension", 1)
        self.level = _check_int(level, "level", 0)
        self._max_1d_level = self.level + 1
        self._denominator = 2 ** max(self._max_1d_level - 1, 1)
        # a node differs from the midpoint in at most `level` coordinates: it is held as
        # those entries (dimension, position), which costs O(N level) instead of O(N n)
        self._entry_dims, self._entry_positions = self._sparse_nodes()

    @property
    def midpoint_position(self) -> int:
        """Position of the midpoint 0.5 on the common integer scale (:attr:`denominator`)."""
        return self._denominator // 2

    @property
    def denominator(self) -> int:
        """The common integer scale of the 1-D node positions: node = (1 - cos(pi p / D)) / 2."""
        return self._denominator

    @property
    def entries(self) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
        """The nodes as their coordinates off the midpoint: ``(dims, positions)``, each (N, level).

        Row r lists node r's coordinates that are not 0.5, by increasing dimension;
        unused slots hold the dimension ``n`` and the midpoint position. Node r is
        0.5 everywhere except ``nodes[r, dims[r, t]] = node value of positions[r, t]``
        (values: :func:`nodes_1d` of the common scale :attr:`denominator`).
        """
        return self._entry_dims, self._entry_positions

    def _sparse_nodes(self) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
        """Every node as entries off the midpoint, in the order of :attr:`nodes`.

        A node with 1-D levels ``l_d`` (1 at the midpoint) lies first in the tensor
        grid of the multi-index ``i = l``; the grids are generated by increasing
        ``(|i|, i)`` and each enumerates its points lexicographically, so the node
        order is the sort by ``sum(l_d - 1)``, then ``l`` as a tuple, then the
        positions. With the entries in increasing dimension, ``l`` compares at its
        first raised entry: a smaller dimension there means a larger tuple.
        """
        n, k, denominator = self.dimension, self.level, self._denominator
        middle = denominator // 2
        dims: list[NDArray[np.intp]] = [np.full((1, k), n, dtype=np.intp)]
        positions: list[NDArray[np.int64]] = [np.full((1, k), middle, dtype=np.int64)]
        levels: list[NDArray[np.int64]] = [np.ones((1, k), dtype=np.int64)]
        for pattern in _level_patterns(k, min(k, n)):
            width = len(pattern)
            # positions new at each entry's 1-D level, all combinations (first entry slowest)
            choices = _cartesian_int([_new_positions_1d(i, denominator) for i in pattern])
            combos = _combinations(n, width)
            rows = len(combos) * len(choices)
            entry_dims = np.full((rows, k), n, dtype=np.intp)
            entry_positions = np.full((rows, k), middle, dtype=np.int64)
            entry_levels = np.ones((rows, k), dtype=np.int64)
            entry_dims[:, :width] = np.repeat(combos, len(choices), axis=0)
            entry_positions[:, :width] = np.tile(choices, (len(combos), 1))
            entry_levels[:, :width] = pattern
            dims.append(entry_dims)
            positions.append(entry_positions)
            levels.append(entry_levels)
        all_dims = np.concatenate(dims)
        all_positions = np.concatenate(positions)
        all_levels = np.concatenate(levels)
        keys = [(all_levels - 1).sum(axis=1)]
        keys += [key for t in range(k) for key in (-all_dims[:, t], all_levels[:, t])]
        keys += [all_positions[:, t] for t in range(k)]
        order = np.lexsort(keys[::-1])
        return all_dims[order], all_positions[order]

    @cached_property
    def nodes(self) -> NDArray[np.float64]:
        """(N, n) unique nodes, ordered by the tensor grid that first holds them, then
        lexicographically (built on first use: N x n numbers)."""
        values = np.full((len(self), self.dimension), 0.5)
        used = self._entry_dims < self.dimension
        rows = np.nonzero(used)[0]
        values[rows, self._entry_dims[used]] = _node_values(
            self._entry_positions[used], self._denominator
        )
        values.setflags(write=False)
        return values

    @cached_property
    def terms(self) -> list[tuple[tuple[int, ...], float]]:
        """Multi-indices of the combination technique, their coefficients (built on first use)."""
        n, q = self.dimension, self.dimension + self.level
        terms: list[tuple[tuple[int, ...], float]] = []
        for index in self._multi_indices(max(n, q - n + 1), q):
            excess = q - sum(index)
            terms.append((index, float((-1) ** excess * comb(n - 1, excess))))
        return terms

    @cached_property
    def _term_nodes(self) -> list[NDArray[np.intp]]:
        """Node rows of every term's tensor grid, in the grid's enumeration order."""
        middle = self._denominator // 2
        lookup = {
            tuple((d, p) for d, p in zip(dims, positions, strict=True) if d < self.dimension): row
            for row, (dims, positions) in enumerate(
                zip(self._entry_dims.tolist(), self._entry_positions.tolist(), strict=True)
            )
        }
        found = []
        for index, _ in self.terms:
            raised = [(d, i) for d, i in enumerate(index) if i > 1]
            axes = [_positions_1d(i, self._denominator).tolist() for _, i in raised]
            found.append(
                np.array(
                    [
                        lookup[
                            tuple(
                                (d, p)
                                for (d, _), p in zip(raised, point, strict=True)
                                if p != middle
                            )
                        ]
                        for point in itertools.product(*axes)
                    ],
                    dtype=np.intp,
                )
            )
        return found

    def _multi_indices(self, low: int, high: int) -> list[tuple[int, ...]]:
        """All i in N^n (i_j >= 1) with low <= |i| <= high, by increasing |i|."""
        found: list[tuple[int, ...]] = []
        dimension = self.dimension

        def raised(start: int, budget: int) -> Iterator[list[tuple[int, int]]]:
            # the entries above 1, as (position, extra) at positions >= start with extras
            # summing to at most budget: recursion as deep as the level, never the dimension
            yield []
            for position in range(start, dimension):
                for extra in range(1, budget + 1):
                    for rest in raised(position + 1, budget - extra):
                        yield [(position, extra), *rest]

        for entries in raised(0, high - dimension):
            index = [1] * dimension
            for position, extra in entries:
                index[position] += extra
            if dimension + sum(extra for _, extra in entries) >= low:
                found.append(tuple(index))
        return sorted(found, key=lambda index: (sum(index), index))

    def __len__(self) -> int:
        return len(self._entry_dims)

    def __repr__(self) -> str:
        return f"SparseGrid(dimension={self.dimension}, level={self.level}, nodes={len(self)})"

    @cached_property
    def _nodes_1d(self) -> dict[int, NDArray[np.float64]]:
        return {
            i: _node_values(_positions_1d(i, self._denominator), self._denominator)
            for i in range(1, self._max_1d_level + 1)
        }

    def _checked_points(self, points: ArrayLike) -> NDArray[np.float64]:
        array = np.asarray(points, dtype=float)
        if array.ndim == 1 and self.dimension == 1:
            array = array[:, None]
        if array.ndim != 2 or array.shape[1] != self.dimension:
            raise InvalidParameterError(
                f"points must have shape (P, {self.dimension}), got {np.shape(points)}"
            )
        if not np.all(np.isfinite(array)):
            raise InvalidParameterError("points must be finite")
        if array.size and (array.min() < -1e-12 or array.max() > 1.0 + 1e-12):
            raise InvalidParameterError(
                f"points must lie in the unit cube [0, 1]^{self.dimension} (the interpolant "
                f"is not meant for extrapolation), got values in [{array.min()}, {array.max()}]"
            )
        return array

    def weights(self, points: ArrayLike) -> NDArray[np.float64]:
        """Interpolation weights W (P, N): interpolant values at ``points`` are ``W @ values``.

        Parameters
        ----------
        points : array_like, shape (P, n)
            Points in [0, 1]^n.

        Returns
        -------
        ndarray, shape (P, N)
            Row p holds the weight of every node in the interpolant at point p.
            At a node the row is that node's unit vector (up to round-off).
        """
        x = self._checked_points(points)
        count = len(x)
        # basis[d][i]: (m_i, P) Lagrange basis of 1-D level i >= 2 in dimension d (level 1 is 1)
        basis = [
            {i: _lagrange_basis(x[:, d], nodes).T for i, nodes in self._nodes_1d.items() if i > 1}
            for d in range(self.dimension)
        ]
        # accumulate node-major (N, P): each term adds whole rows
        result = np.zeros((len(self), count))
        for (index, coefficient), rows in zip(self.terms, self._term_nodes, strict=True):
            tensor = np.full((1, count), coefficient)
            for d, i in enumerate(index):
                if i > 1:
                    factor = basis[d][i]
                    tensor = (tensor[:, None, :] * factor[None, :, :]).reshape(-1, count)
            result[rows] += tensor
        return result.T

    def interpolate(self, points: ArrayLike, values: ArrayLike) -> NDArray[np.float64]:
        """Interpolant at ``points`` of data ``values`` given at the nodes.

        Parameters
        ----------
        points : array_like, shape (P, n)
            Points in [0, 1]^n.
        values : array_like, shape (N, ...)
            Data at :attr:`nodes` (any trailing shape, e.g. a time signal).

        Returns
        -------
        ndarray, shape (P, ...)
            Computed in blocks of points so that no block of weights or results
            exceeds a few million numbers.
        """
        data = np.asarray(values, dtype=float)
        if data.ndim == 0 or data.shape[0] != len(self):
            raise InvalidParameterError(
                f"values must have leading axis N={len(self)} (one row per node), "
                f"got shape {data.shape}"
            )
        x = self._checked_points(points)
        flat = data.reshape(len(self), -1)
        result = np.empty((len(x), flat.shape[1]))
        block = max(1, _BLOCK_ELEMENTS // max(len(self), flat.shape[1]))
        for start in range(0, len(x), block):
            stop = min(start + block, len(x))
            result[start:stop] = self.weights(x[start:stop]) @ flat
        return result.reshape((len(x), *data.shape[1:]))


def node_count(dimension: int, level: int) -> int:
    """Number of nodes of the Clenshaw-Curtis Smolyak grid, without building it.

    ``[z^level] (1 - 2z^2)^n / ((1 - 2z)^n (1 - z))`` (module docstring), exact
    in integer arithmetic; O(level^2) operations.

    Parameters
    ----------
    dimension : int
        Number of variables n >= 0 (n = 0: the single point of a 0-D grid).
    level : int
        Sparse-grid level ``q - n >= 0``.

    Examples
    --------
    >>> [node_count(3, level) for level in range(5)]
    [1, 7, 25, 69, 177]
    """
    n = _check_int(dimension, "dimension", 0)
    k = _check_int(level, "level", 0)
    # coefficients of (1 - 2z)^(-n) up to z^k: binom(n + b - 1, b) 2^b
    inverse = [1] * (k + 1)
    for b in range(1, k + 1):
        inverse[b] = inverse[b - 1] * 2 * (n + b - 1) // b
    total = 0
    for s in range(k + 1):  # coefficient of z^s of (1 - 2z^2)^n (1 - 2z)^(-n), summed
        total += sum(comb(n, a) * (-2) ** a * inverse[s - 2 * a] for a in range(s // 2 + 1))
    return total


def nodes_1d(level: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The 1-D nodes a grid of ``level`` uses (bit-identical to its nodes) and their 1-D levels.

    Returns
    -------
    values : ndarray, shape (K,)
        Nodes in [0, 1], increasing; ``K = 1`` for level 0, else ``2^level + 1``.
    levels : ndarray of int, shape (K,)
        The 1-D level ``i`` (1 = the midpoint, 2 = the ends, ...) that first holds each node.
    """
    k = _check_int(level, "level", 0)
    denominator = 2 ** max(k, 1)
    positions = np.arange(denominator + 1, dtype=np.int64)
    # 1-D level of position p: the midpoint is level 1, the ends level 2, an odd multiple of
    # denominator / 2^(i-1) level i
    lowest_bit = positions & -positions
    first = np.where(positions == 0, 2, k + 1 - np.log2(np.maximum(lowest_bit, 1)).astype(np.int64))
    first[positions == denominator] = 2
    first[positions == denominator // 2] = 1
    keep = first <= k + 1
    return _node_values(positions[keep], denominator), first[keep]


def sparse_grid(n: int, level: int) -> NDArray[np.float64]:
    """Nodes (N, n) of the Clenshaw-Curtis Smolyak grid of ``level = q - n`` in [0, 1]^n.

    See :class:`SparseGrid` for the construction and the node order.
    """
    return SparseGrid(n, level).nodes
