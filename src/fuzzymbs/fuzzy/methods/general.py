"""The general method (Hanss 2002): interior points in every parameter.

Per parameter the points ``P_m`` = the core bounds (one point for a single-point
core) and, for j < m, ``P_j = {a^(j)} + midpoints of consecutive points of
P_(j+1) + {b^(j)}`` (``M_j = m + 1 - j`` points); all combinations at every
level. Exact at its points for any model; the runs grow as ``(m + 2)^n``.
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzymbs.fuzzy.methods.level_scheme import LevelScheme

__all__ = ["General"]


@dataclass(frozen=True)
class General(LevelScheme):
    """The general transformation method: no options."""

    name = "general"
    summary = "every combination of each level's points P_j; for non-monotonic models"

    def interior_flags(self, names: tuple[str, ...]) -> list[bool]:
        return [True] * len(names)
