"""What retransformation and the influence measures read from a plan: its bookkeeping.

A plan knows which sample belongs to which alpha level and which pairs of
samples differ in one parameter only; :mod:`fuzzymbs.fuzzy.retransform` and
:mod:`fuzzymbs.fuzzy.influence` use that bookkeeping and nothing else.
:class:`PlanBookkeeping` states it, so those modules need not import
:mod:`fuzzymbs.fuzzy.transform`: the plan (built there) hands itself down to
them, and imports point one way, transform -> retransform -> influence.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.fuzzy.methods.base import Method
from fuzzymbs.fuzzy.sparse_grid import SparseGrid

__all__ = ["PlanBookkeeping"]


class PlanBookkeeping(Protocol):
    """The part of :class:`~fuzzymbs.fuzzy.transform.Plan` that its consumers read.

    Attributes
    ----------
    names : tuple of str
        Parameter names (column order of ``samples``).
    levels : ndarray, shape (L,)
        Membership levels mu_0 = 0 ... mu_m = 1.
    method : str
        The method's public name.
    scheme : Method
        The method object, whose capabilities say what the bookkeeping holds
        (:mod:`fuzzymbs.fuzzy.methods`).
    nonmonotonic : tuple of str
        Parameters with interior points (``"extended"`` only).
    search_points : int or None
        Search points per cut box (``"sparse"`` only).
    samples : ndarray, shape (N, n)
        Unique sample points.
    cut_lower, cut_upper : ndarray, shape (L, n)
        Alpha-cut bounds of every parameter at every level.
    """

    names: tuple[str, ...]
    levels: NDArray[np.float64]
    method: str
    scheme: Method
    nonmonotonic: tuple[str, ...]
    search_points: int | None
    samples: NDArray[np.float64]
    cut_lower: NDArray[np.float64]
    cut_upper: NDArray[np.float64]

    def __len__(self) -> int:
        """Number of samples N."""
        ...

    @property
    def nominal_index(self) -> int:
        """Row of ``samples`` holding the all-modal point."""
        ...

    @property
    def level_usage(self) -> NDArray[np.bool_]:
        """(L, N) bool: sample i is one of the points evaluated at level j."""
        ...

    @property
    def corner_index(self) -> NDArray[np.intp]:
        """(L, 2^n) sample index of the cut-box corners (reduced and extended plans)."""
        ...

    @property
    def sparse_grid(self) -> SparseGrid:
        """The sparse grid on the unit cube (sparse plans)."""
        ...

    @property
    def node_index(self) -> NDArray[np.intp]:
        """Sample index of every sparse-grid node (sparse plans)."""
        ...

    def level_indices(self, level: int) -> NDArray[np.intp]:
        """Sample indices of the points of level ``level``."""
        ...

    def check_failed(self, failed: ArrayLike | None) -> NDArray[np.bool_]:
        """Validated (N,) failed-sample mask (all False for None)."""
        ...

    def levels_touched(self, failed: ArrayLike) -> NDArray[np.bool_]:
        """(L,) bool: levels whose nested bounds depend on a failed sample."""
        ...

    def to_unit_cube(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map parameter points (P, n) of the support box to [0, 1]^n."""
        ...

    def retransform(
        self, outputs: Any, failed: ArrayLike | None = None, *, check_monotonic: bool = True
    ) -> Any:
        """The fuzzy result of outputs at the samples (what the influence measures start
        from)."""
        ...
