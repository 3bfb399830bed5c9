"""What the general, reduced, extended and grid methods share: a full factorial per level.

At level j these methods evaluate the full factorial of one value set per
parameter (:mod:`fuzzymbs.fuzzy.level_values`). :class:`LevelScheme` builds the
samples from those sets and counts them from the same sets
(:func:`~fuzzymbs.fuzzy.level_values.union_size`), so the count is ``len(plan)``;
only for absurdly many parameters x levels does a closed form, an upper bound,
stand in (docs/theory.md, "Sampling schemes and their counts").
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.grids import cartesian, unique_rows
from fuzzymbs.fuzzy.level_values import bound_value_sets, union_size
from fuzzymbs.fuzzy.methods.base import CountRequest, Method, NumberShape, Sampling
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import make_levels

__all__ = ["LevelScheme", "level_scheme_count", "power_product_sum"]

#: exact counts build each parameter's value sets: at most this many cuts (parameters x
#: levels), and this many values over all parameters and levels
EXACT_CUTS = 100_000
EXACT_VALUES = 2_000_000


def power_product_sum(steps: int, p: int, q: int) -> int:
    """``sum_(k=1)^m (k + 1)^p (k + 2)^q``, exactly, in O((p + q)^2) operations.

    The partial sum is a polynomial of degree ``d = p + q + 1`` in m; Newton's
    forward-difference formula ``S(m) = sum_t Delta^t S(0) binom(m, t)`` extends
    it from ``S(0..d)``.
    """
    degree = p + q + 1
    partial = [0]
    for k in range(1, min(steps, degree) + 1):
        partial.append(partial[-1] + (k + 1) ** p * (k + 2) ** q)
    if steps <= degree:
        return partial[steps]
    total = 0
    differences = partial
    for t in range(degree + 1):
        total += differences[0] * math.comb(steps, t)
        differences = [b - a for a, b in itertools.pairwise(differences)]
    return total


def _modal_levels(shape: NumberShape, general: bool) -> str:
    """Levels whose points hold the modal value: "all", "top" (m), "next" (m - 1) or "none"."""
    if shape.point_core:  # the core point is a cut bound
        return "all" if shape.flat_left or shape.flat_right else "top"
    # the core midpoint is the general method's first inner point (level m - 1)
    return "next" if general else "none"


def _modal_is_level_point(kinds: Iterable[str]) -> bool:
    """Whether the all-modal point is one of the points of some level."""
    found = set(kinds)
    if "none" in found:
        return False
    return len(found - {"all"}) <= 1  # "top" and "next" name different levels


def _product(values: Iterable[int]) -> int:
    return math.prod(values, start=1)


def level_scheme_count(shapes: list[NumberShape], interior: list[bool], steps: int) -> int:
    """Runs of the reduced, extended and general schemes, in closed form (an upper bound).

    Level j = m - k evaluates the product of per-parameter value sets: the two
    bounds ``{a^(j), b^(j)}`` (one at a point core or a crisp value), or the
    general method's ``P_j`` with ``k + 1`` or ``k + 2`` values (point or
    interval core; a crisp value: one). A value is either held by one level only
    or, the bound of a flat branch, by all, so the union of the levels is
    ``sum_j |X_j| - m H`` with ``H = prod_i shared_i`` points common to every
    level; the all-modal point adds one run unless it is a level's point.
    """
    corner = [s for s, inner in zip(shapes, interior, strict=True) if not inner]
    general = [s for s, inner in zip(shapes, interior, strict=True) if inner]
    top = _product(s.core_size for s in shapes)  # level m: the core values (P_m = core)
    corners_below = _product(1 if s.crisp else 2 for s in corner)
    points = sum(1 for s in general if not s.crisp and s.point_core)
    intervals = sum(1 for s in general if not s.crisp and not s.point_core)
    below = corners_below * power_product_sum(steps, points, intervals)
    common = _product(s.shared for s in shapes)
    kinds = [_modal_levels(s, inner) for s, inner in zip(shapes, interior, strict=True)]
    return top + below - steps * common + (0 if _modal_is_level_point(kinds) else 1)


@dataclass(frozen=True)
class LevelScheme(Method):
    """A method that evaluates, at every level, the full factorial of per-parameter value
    sets (subclasses say which sets: :meth:`value_sets`)."""

    def interior_flags(self, names: tuple[str, ...]) -> list[bool]:
        """Per parameter: whether it takes the general method's points."""
        return [False] * len(names)

    def value_sets(
        self, names: tuple[str, ...], cut_lower: NDArray, cut_upper: NDArray
    ) -> list[list[NDArray[np.float64]]]:
        """``values[j][i]``: the coordinates parameter i takes at level j (by default the cut
        bounds, or the general method's points for the :meth:`interior_flags`)."""
        return bound_value_sets(cut_lower, cut_upper, self.interior_flags(names))

    def closed_form(self, request: CountRequest) -> int:
        """The count from the numbers' shapes alone (an upper bound of ``len(plan)``)."""
        return level_scheme_count(request.shapes, self.interior_flags(request.names), request.steps)

    # ------------------------------------------------------------------ count
    def count(self, request: CountRequest) -> tuple[int, bool]:
        """The distinct points of the builder's own value sets (exact), or the closed form
        (an upper bound) beyond :data:`EXACT_CUTS` cuts or :data:`EXACT_VALUES` values."""
        count_levels = request.steps + 1
        numbers = request.numbers
        per_level = self._values_per_level(request)
        if (
            len(numbers) * count_levels > EXACT_CUTS
            or len(numbers) * count_levels * per_level > EXACT_VALUES
        ):
            return self.closed_form(request), False
        mu = make_levels(request.levels)
        cuts = np.stack([number.cuts(mu) for number in numbers], axis=1)
        values = self.value_sets(request.names, cuts[:, :, 0], cuts[:, :, 1])
        return union_size(values, [number.modal for number in numbers]), True

    def _values_per_level(self, request: CountRequest) -> int:
        """The most values a parameter takes at one level (the cost of an exact count)."""
        return request.steps + 2 if any(self.interior_flags(request.names)) else 2

    # ------------------------------------------------------------------ build
    def build(
        self, parameters: dict[str, FuzzyNumber], cut_lower: NDArray, cut_upper: NDArray
    ) -> Sampling:
        """Modal point first, then the levels from the core down, merged by exact equality."""
        count_levels = len(cut_lower)
        names = tuple(parameters)
        modal_point = np.array([[number.modal for number in parameters.values()]])
        level_points = [
            cartesian(values) for values in self.value_sets(names, cut_lower, cut_upper)
        ]
        # nominal point first, then levels from the core down, so that samples
        # are ordered by first use from the top level
        blocks = [modal_point, *level_points[::-1]]
        sizes = [len(block) for block in blocks]
        unique, inverse = unique_rows(np.concatenate(blocks, axis=0))
        unique.setflags(write=False)
        offsets = np.cumsum([0, *sizes])
        nominal = int(inverse[0])
        per_level_from_top = [inverse[offsets[k + 1] : offsets[k + 2]] for k in range(count_levels)]
        level_index = per_level_from_top[::-1]
        # the nominal point lies in the core box: it belongs to the top level
        level_index[-1] = np.concatenate((level_index[-1], [nominal]))
        # runs if every level were evaluated on its own (repeats inside a level merged)
        without_reuse = sum(len(unique_rows(points)[0]) for points in level_points)
        usage = np.zeros((count_levels, len(unique)), dtype=bool)
        for j, index in enumerate(level_index):
            usage[j, index] = True
        usage.setflags(write=False)
        corners = _corners(unique, cut_lower, cut_upper) if self.has_corners else None
        return Sampling(unique, level_index, nominal, without_reuse, usage, corners)


def _corners(
    samples: NDArray[np.float64], cut_lower: NDArray, cut_upper: NDArray
) -> NDArray[np.intp]:
    """Sample index of every corner: (L, 2^n), corner s uses b_i where bit n-1-i of s is set.

    Corner s and s + 2^(n-1-i) differ only in parameter i (a_i then b_i).
    """
    count_levels, count_parameters = cut_lower.shape
    bits = (np.arange(2**count_parameters)[:, None] >> np.arange(count_parameters - 1, -1, -1)) & 1
    corner_index = np.empty((count_levels, 2**count_parameters), dtype=np.intp)
    for j in range(count_levels):
        corners = np.where(bits == 1, cut_upper[j], cut_lower[j])
        combined = np.concatenate((samples, corners), axis=0)
        unique, inverse = unique_rows(combined)
        if len(unique) != len(samples):  # pragma: no cover - internal consistency
            raise RuntimeError("corner point missing from the sample table")
        corner_index[j] = inverse[len(samples) :]
    return corner_index
