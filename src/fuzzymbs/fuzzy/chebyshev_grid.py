"""A dimension-adaptive sparse grid on Clenshaw-Curtis nodes, held as a Chebyshev series.

The surrogate of the adaptive transformation method (:mod:`fuzzymbs.fuzzy.adaptive`):
one interpolant of every output element at once over the cube ``[-1, 1]^n``.

Construction (Gerstner & Griebel, Computing 71 (2003) 65, for the index sets;
Barthelmann, Novak & Ritter, Adv. Comput. Math. 12 (2000) 273 for the
combination formula; Trefethen, Approximation Theory and Approximation
Practice, ch. 3, for Chebyshev interpolation on Chebyshev points):

* 1-D level ``l``: ``m_0 = 1`` node (0), ``m_l = 2^l + 1`` Clenshaw-Curtis nodes
  ``-cos(pi k / 2^l)`` above; the sets are nested, level ``l`` adds ``m_l - m_(l-1)``.
* ``U_l``: the polynomial of degree ``m_l - 1`` through those nodes, kept as its
  Chebyshev coefficients (the inverse of the Chebyshev-Vandermonde matrix on
  Chebyshev points is well conditioned).
* A downward-closed set ``I`` of multi-indices ``k`` gives the interpolant
  ``A_I = sum_(k in I) Delta_k`` with the hierarchical surplus
  ``Delta_k = sum_(e in {0,1}^n, k - e >= 0) (-1)^|e| U_(k-e)`` (tensor products
  of the 1-D ``U``); with nested nodes ``A_I`` interpolates at every node of ``I``.
  Summed in Chebyshev form ``A_I`` is a single series: a matrix of coefficients
  (one row per multi-degree, one column per output element).
* With the model's first derivatives at the nodes, ``U_l`` along one direction can
  be the Hermite interpolant instead: values and derivatives at the same ``m_l``
  nodes, degree ``2 m_l - 1`` (:meth:`ChebyshevSparseGrid.use_hermite`). Along one
  direction only: a tensor product of Hermite interpolants in two directions would
  need the mixed derivatives.
* Refinement adds forward neighbours ``k + e_i`` whose backward neighbours are all
  in ``I`` (admissible); which ones, is the caller's choice (the surpluses ``Delta_k``
  of the newest indices are the error indicator).

Nodes carry integer positions on a common scale (``p / 2^MAX_LEVEL``), so a
node shared by several levels is one point, bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache
from itertools import product

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_LEVEL", "ChebyshevSparseGrid", "chebyshev_basis"]

#: finest 1-D level (1025 nodes per direction)
MAX_LEVEL = 10
_SCALE = 2**MAX_LEVEL


def _positions(level: int) -> NDArray[np.int64]:
    """Integer positions of the nodes of 1-D ``level`` (``x = -cos(pi p / 2^MAX_LEVEL)``)."""
    if level == 0:
        return np.array([_SCALE // 2], dtype=np.int64)
    return np.arange(0, _SCALE + 1, _SCALE >> level, dtype=np.int64)


def _new_positions(level: int) -> NDArray[np.int64]:
    """Positions level ``level`` adds to level ``level - 1``."""
    if level == 0:
        return _positions(0)
    if level == 1:
        return np.array([0, _SCALE], dtype=np.int64)
    step = _SCALE >> level
    return np.arange(step, _SCALE, 2 * step, dtype=np.int64)


def node_values(positions: NDArray[np.int64]) -> NDArray[np.float64]:
    """Nodes ``-cos(pi p / S)`` written with the sine: 0, -1 and 1 come out exactly."""
    return 0.0 - np.sin(np.pi * (_SCALE - 2 * np.asarray(positions)) / (2 * _SCALE))


@cache
def _to_coefficients(level: int) -> NDArray[np.float64]:
    """(m, m) matrix from values at the nodes of ``level`` to Chebyshev coefficients."""
    x = node_values(_positions(level))
    vandermonde = np.cos(np.arange(len(x))[None, :] * np.arccos(np.clip(x, -1, 1))[:, None])
    inverse = np.linalg.inv(vandermonde)
    inverse.setflags(write=False)
    return inverse


@cache
def _hermite_to_coefficients(level: int) -> NDArray[np.float64]:
    """(2m, 2m) matrix from the values and then the first derivatives at the m nodes of
    ``level`` to the Chebyshev coefficients of their Hermite interpolant (degree ``2m - 1``;
    condition numbers 26, 81, 277, 1065 and 4473 at levels 1 to 5:
    benchmarks/hermite_direction.py)."""
    x = node_values(_positions(level))
    value, slope = chebyshev_basis(x, 2 * len(x) - 1, derivative=True)
    inverse = np.linalg.inv(np.vstack((value, slope)))
    inverse.setflags(write=False)
    return inverse


def chebyshev_basis(
    x: NDArray[np.float64], degree: int, derivative: bool = False
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``T_a(x)`` for a = 0..degree, (P, degree + 1), by the three-term recurrence;
    with ``derivative`` also ``T_a'(x)``."""
    x = np.asarray(x, dtype=float)
    table = np.empty((len(x), degree + 1))
    table[:, 0] = 1.0
    if degree >= 1:
        table[:, 1] = x
    for a in range(2, degree + 1):
        table[:, a] = 2.0 * x * table[:, a - 1] - table[:, a - 2]
    if not derivative:
        return table
    slope = np.zeros_like(table)
    if degree >= 1:
        slope[:, 1] = 1.0
    for a in range(2, degree + 1):
        slope[:, a] = 2.0 * table[:, a - 1] + 2.0 * x * slope[:, a - 1] - slope[:, a - 2]
    return table, slope


def _apply_along(values: NDArray[np.float64], matrices: list[NDArray]) -> NDArray[np.float64]:
    """Apply ``matrices[i]`` along axis i of ``values`` (shape (m_1, ..., m_n, E))."""
    out = values
    for axis, matrix in enumerate(matrices):
        out = np.moveaxis(np.tensordot(matrix, out, axes=([1], [axis])), 0, axis)
    return out


class ChebyshevSparseGrid:
    """Dimension-adaptive sparse grid of ``n`` directions; see the module docstring.

    Parameters
    ----------
    dimension : int
        Number of directions n.
    frozen : iterable of int, optional
        Directions never refined (a parameter of zero width).

    Attributes
    ----------
    indices : list of tuple of int
        The multi-indices in the order they were added (downward closed).
    expanded : set of tuple of int
        Indices whose forward neighbours were offered (the "old" set).
    hermite : int or None
        The direction along which the interpolant takes the nodes' derivatives too
        (:meth:`use_hermite`), None for values only.
    """

    def __init__(self, dimension: int, frozen: Iterable[int] = ()) -> None:
        self.dimension = int(dimension)
        self.frozen = frozenset(int(i) for i in frozen)
        self.indices: list[tuple[int, ...]] = []
        self._index_set: set[tuple[int, ...]] = set()
        self.expanded: set[tuple[int, ...]] = set()
        self._row: dict[tuple[int, ...], int] = {}  # node positions -> row of values
        self._values: NDArray[np.float64] | None = None
        # per row of values its first derivatives (E, n) on the cube (None until some are
        # given: a model without gradients stores none) and whether they were given
        self._slopes: NDArray[np.float64] | None = None
        self._sloped = np.empty(0, dtype=bool)
        self.hermite: int | None = None
        # tensor coefficients and the set's series per Hermite direction (None: values only)
        self._tensor: dict[tuple[tuple[int, ...], int | None], NDArray[np.float64]] = {}
        self._series: dict[int | None, tuple[NDArray[np.int64], NDArray[np.float64]]] = {}

    # ------------------------------------------------------------- index sets
    def new_nodes(self, index: tuple[int, ...]) -> list[tuple[int, ...]]:
        """Positions of the nodes ``index`` adds to its backward neighbours."""
        return [tuple(int(p) for p in q) for q in product(*(_new_positions(k) for k in index))]

    def admissible(self, index: tuple[int, ...]) -> bool:
        """All backward neighbours in the set, not in it yet, within MAX_LEVEL and not frozen."""
        if index in self._index_set or max(index) > MAX_LEVEL:
            return False
        for i, k in enumerate(index):
            if k > 0 and i in self.frozen:
                return False
            if k > 0 and (*index[:i], k - 1, *index[i + 1 :]) not in self._index_set:
                return False
        return True

    def forward(self, index: tuple[int, ...]) -> list[tuple[int, ...]]:
        """Forward neighbours of ``index`` that would be admissible once it is in the set."""
        found = []
        for i in range(self.dimension):
            candidate = (*index[:i], index[i] + 1, *index[i + 1 :])
            if self.admissible(candidate):
                found.append(candidate)
        return found

    @property
    def active(self) -> list[tuple[int, ...]]:
        """Indices not expanded yet (the frontier), in the order they were added."""
        return [k for k in self.indices if k not in self.expanded]

    def add_index(self, index: tuple[int, ...]) -> list[tuple[int, ...]]:
        """Put an admissible index into the set; returns the positions of its new nodes."""
        if not self.admissible(index):
            raise ValueError(f"index {index} is not admissible")
        self.indices.append(index)
        self._index_set.add(index)
        self._series.clear()
        return [q for q in self.new_nodes(index) if q not in self._row]

    def remove_index(self, index: tuple[int, ...]) -> None:
        """Take ``index`` out of the set again (its node values stay)."""
        self.indices.remove(index)
        self._index_set.discard(index)
        self._series.clear()

    def __contains__(self, index: object) -> bool:
        """``index`` is in the set."""
        return index in self._index_set

    def set_values(
        self,
        positions: list[tuple[int, ...]],
        values: NDArray[np.float64],
        slopes: NDArray[np.float64] | None = None,
    ) -> None:
        """The model's outputs (P, E) at node positions, and optionally their first
        derivatives (P, E, n) with respect to the cube's coordinates."""
        values = np.asarray(values, dtype=float).reshape(len(positions), -1)
        start = 0 if self._values is None else len(self._values)
        for offset, q in enumerate(positions):
            self._row[q] = start + offset
        self._values = values if self._values is None else np.concatenate((self._values, values))
        self._sloped = np.concatenate((self._sloped, np.full(len(values), slopes is not None)))
        if slopes is not None or self._slopes is not None:
            given = (
                np.zeros((*values.shape, self.dimension))
                if slopes is None
                else np.asarray(slopes, dtype=float).reshape(*values.shape, self.dimension)
            )
            known = (
                self._slopes
                if self._slopes is not None
                else np.zeros((start, values.shape[1], self.dimension))
            )
            self._slopes = np.concatenate((known, given))
        self._series.clear()

    def use_hermite(self, direction: int | None) -> None:
        """Interpolate the values and first derivatives along ``direction``, the values
        only along the others; None: the values only everywhere.

        Raises
        ------
        ValueError
            A direction out of range, or a node without its derivatives.
        """
        if direction is not None:
            if not 0 <= direction < self.dimension:
                raise ValueError(f"direction {direction} is not one of 0..{self.dimension - 1}")
            if not self.has_slopes():
                raise ValueError("a Hermite direction needs the derivatives at every node")
        self.hermite = direction

    def has_slopes(self) -> bool:
        """Every node carries its first derivatives (given to :meth:`set_values`)."""
        return self._slopes is not None and bool(self._sloped.all())

    def has_values(self, index: tuple[int, ...]) -> bool:
        """Every node of ``index`` has a value."""
        return all(q in self._row for q in self.new_nodes(index))

    # ---------------------------------------------------------------- series
    def _tensor_coefficients(
        self, index: tuple[int, ...], hermite: int | None = None
    ) -> NDArray[np.float64]:
        """Chebyshev coefficients (m_1, ..., m_n, E) of the tensor interpolant ``U_index``,
        ``2 m`` of them along the ``hermite`` direction (values and derivatives)."""
        known = self._tensor.get((index, hermite))
        if known is not None:
            return known
        axes = [_positions(k) for k in index]
        rows = [self._row[tuple(int(p) for p in q)] for q in product(*axes)]
        assert self._values is not None
        shape = tuple(len(a) for a in axes)
        values = self._values[rows].reshape(*shape, -1)
        matrices = [_to_coefficients(k) for k in index]
        if hermite is not None:
            assert self._slopes is not None
            slopes = self._slopes[rows, :, hermite].reshape(*shape, -1)
            values = np.concatenate((values, slopes), axis=hermite)
            matrices[hermite] = _hermite_to_coefficients(index[hermite])
        coefficients = _apply_along(values, matrices)
        self._tensor[(index, hermite)] = coefficients
        return coefficients

    def surplus(self, index: tuple[int, ...]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """``Delta_index`` as (degrees (D, n), coefficients (D, E)) of its Chebyshev series."""
        own = self._tensor_coefficients(index, self.hermite)
        total = own.copy()
        for step in product((0, 1), repeat=self.dimension):
            if not any(step):
                continue
            back = tuple(k - s for k, s in zip(index, step, strict=True))
            if min(back) < 0:
                continue
            coefficients = self._tensor_coefficients(back, self.hermite)
            region = tuple(slice(0, m) for m in coefficients.shape[:-1])
            total[region] += (-1) ** sum(step) * coefficients
        degrees = np.indices(own.shape[:-1]).reshape(self.dimension, -1).T
        return degrees, total.reshape(len(degrees), -1)

    def series(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The interpolant of the whole set: (degrees (D, n), coefficients (D, E))."""
        known = self._series.get(self.hermite)
        if known is not None:
            return known
        members = self._index_set
        rows: dict[tuple[int, ...], int] = {}
        blocks: list[tuple[list[int], NDArray[np.float64]]] = []
        for index in self.indices:
            weight = 0
            for step in product((0, 1), repeat=self.dimension):
                if tuple(k + s for k, s in zip(index, step, strict=True)) in members:
                    weight += (-1) ** sum(step)
            if weight == 0:
                continue
            coefficients = self._tensor_coefficients(index, self.hermite)
            degrees = np.indices(coefficients.shape[:-1]).reshape(self.dimension, -1).T
            where = []
            for d in map(tuple, degrees.tolist()):
                if d not in rows:
                    rows[d] = len(rows)
                where.append(rows[d])
            blocks.append((where, weight * coefficients.reshape(len(degrees), -1)))
        width = blocks[0][1].shape[1]
        total = np.zeros((len(rows), width))
        for where, block in blocks:
            total[where] += block
        degrees_all = np.array(list(rows), dtype=np.int64).reshape(len(rows), self.dimension)
        self._series[self.hermite] = (degrees_all, total)
        return degrees_all, total

    def node_count(self) -> int:
        """Nodes with a value."""
        return len(self._row)


def evaluate_series(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    points: NDArray[np.float64],
    block: int = 4096,
) -> NDArray[np.float64]:
    """Values (P, E) of a Chebyshev series at points (P, n) of ``[-1, 1]^n``."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    out = np.empty((len(points), coefficients.shape[1]))
    for start in range(0, len(points), block):
        out[start : start + block] = basis_matrix(degrees, points[start : start + block]) @ (
            coefficients
        )
    return out


def basis_matrix(degrees: NDArray[np.int64], points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(P, D) products ``prod_i T_(a_i)(x_i)`` of the series' multi-degrees at the points."""
    basis = np.ones((len(points), len(degrees)))
    for i in range(degrees.shape[1]):
        top = int(degrees[:, i].max(initial=0))
        if top == 0:
            continue
        table = chebyshev_basis(points[:, i], top)
        basis *= table[:, degrees[:, i]]
    return basis


def basis_gradient(
    degrees: NDArray[np.int64], points: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The basis (P, D) and its gradient (n, P, D) at the points."""
    count = degrees.shape[1]
    tables = []
    for i in range(count):
        top = int(degrees[:, i].max(initial=0))
        value, slope = chebyshev_basis(points[:, i], max(top, 1), derivative=True)
        tables.append((value[:, degrees[:, i]], slope[:, degrees[:, i]]))
    basis = np.ones((len(points), len(degrees)))
    for value, _ in tables:
        basis *= value
    gradient = np.empty((count, len(points), len(degrees)))
    for i in range(count):
        part = tables[i][1].copy()
        for q in range(count):
            if q != i:
                part *= tables[q][0]
        gradient[i] = part
    return basis, gradient
