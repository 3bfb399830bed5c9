"""The reduced method: the 2^n corners of the cut box at every level.

The core box at level m (one point for single-point cores). Exact for models
monotonic in every parameter; corner pairs that differ in one parameter give
the gain factors of the influence measures.
"""

from __future__ import annotations

from dataclasses import dataclass

from fuzzymbs.fuzzy.methods.level_scheme import LevelScheme

__all__ = ["Reduced"]


@dataclass(frozen=True)
class Reduced(LevelScheme):
    """The reduced transformation method: no options."""

    name = "reduced"
    summary = "the cut-box corners of every level; exact for monotonic models (default)"
    supports_influence = True
    has_corners = True
    guards_monotonicity = True
