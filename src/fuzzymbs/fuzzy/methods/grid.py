"""The grid method: at level j the full factorial of all cut bounds of levels j..m.

The full alpha-bound grid: exact on the grid for any model. It holds every
level's cut-box corners too, so it gives the reduced method's influence
measures, while its bounds use every grid point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.level_values import grid_value_sets
from fuzzymbs.fuzzy.methods.base import CountRequest
from fuzzymbs.fuzzy.methods.level_scheme import LevelScheme

__all__ = ["Grid"]


@dataclass(frozen=True)
class Grid(LevelScheme):
    """The full alpha-bound grid: no options."""

    name = "grid"
    summary = "every cut bound of every level combined (the full alpha-bound grid)"
    supports_influence = True
    has_corners = True

    def value_sets(
        self, names: tuple[str, ...], cut_lower: NDArray, cut_upper: NDArray
    ) -> list[list[NDArray[np.float64]]]:
        return grid_value_sets(cut_lower, cut_upper)

    def closed_form(self, request: CountRequest) -> int:
        """Level j's bounds are a subset of level 0's, so the union is level 0."""
        shapes = request.shapes
        modal_extra = any(not s.point_core for s in shapes)  # a core midpoint is no cut bound
        return math.prod((s.bounds(request.steps) for s in shapes), start=1) + int(modal_extra)

    def _values_per_level(self, request: CountRequest) -> int:
        return request.steps + 2
